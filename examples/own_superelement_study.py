"""Bring your own superelements and measured backbones: a small surrogacy study on them.

With a data folder, the superelements are the ASB reduced models exported from ABAQUS (``MAT_NULLRED_<conf>.mat``,
see ``reduction.superelement.read_asb_superelement`` for the fields it reads) and the measurements their measured
backbones (``ASB_<conf>_20Nm_BB.mat`` with Q, W, Z; any backbone CSV of ``experiment.backbone_files`` works too).
Without one, the superelements are the project's three beams (``build/rom``, from ``make rom``) and the
measurements virtual: the QSMA backbone of one known iwan4 joint in each beam (labelled virtual), so every beam
should accept the designs near it.

    python examples/own_superelement_study.py --data data --designs 2000 --out results/example-study
    python examples/own_superelement_study.py --rom build/rom --designs 2000 --out results/example-study
"""

import argparse
from pathlib import Path

import numpy as np

from experiment.backbone_files import read_asb_backbone
from geometry.parameters import BEAM_NAMES
from nonlinear.condensation import joint_space
from pipeline.runners import SERIAL
from reduction.superelement import beam_superelement
from study.analysis import model_errors
from study.errors import accepted
from study.exploration import Exploration, Sample, explore
from study.structures import asb_superelement, qsma_measurement, structure
from study.surrogacy import surrogacy_matrix

MODEL = "iwan4"
# The virtual beams' joint: per patch group {1, 5}, {2, 4}, {3}: F_S (N), K_T (N/m), chi, beta, K_z (N/m).
KNOWN_JOINT = np.array([4e3, 2e8, -0.4, 0.5, 5e9, 6e3, 3e8, -0.3, 1.0, 5e9, 8e3, 4e8, -0.5, 0.3, 5e9])
VIRTUAL_LEVELS = np.geomspace(1e-7, 3e-5, 12)  # modal amplitudes of the virtual backbones, m kg^0.5
VIRTUAL_DAMPING = 1.6659e-3  # the virtual beams' linear damping (the BRB's, paper Table 1)


def asb_structures(data: Path, configurations) -> list:
    """The ASB configurations' reduced models with their measured backbones."""
    return [structure(f"ASB {configuration}",
                      asb_superelement(data / "asb-reduced-models" / f"MAT_NULLRED_{configuration}.mat"),
                      read_asb_backbone(data / "asb-backbones" / f"ASB_{configuration}_20Nm_BB.mat"), 0.0)
            for configuration in configurations]


def virtual_beam_structures(rom: Path) -> list:
    """The three beams' superelements with the virtual backbone of ``KNOWN_JOINT`` in each."""
    structures = []
    for beam in BEAM_NAMES:
        superelement = beam_superelement(rom / f"{beam}.npz")
        measured = qsma_measurement(joint_space(superelement), beam, MODEL, KNOWN_JOINT, VIRTUAL_LEVELS,
                                    VIRTUAL_DAMPING)
        structures.append(structure(beam, superelement, measured, 0.0, len(VIRTUAL_LEVELS)))
    return structures


def run_study(structures: list, designs: int, out: Path, runner=SERIAL):
    """A study of ``designs`` iwan4 designs on the structures (in this process, or on the ``runner`` given:
    ``pipeline.runners``), printing the mode chosen on each and the surrogacy matrix."""
    for structure_ in structures:
        print(structure_.mode_choice)
    damping = {"measured": [float(s.measurement.damping[0]) for s in structures]}
    exploration = Exploration(tuple(structures), (MODEL,), Sample(n_designs=designs, chunk_size=500), damping)
    explore(exploration, out, runner)
    errors = model_errors(out, MODEL, exploration.names, "measured")
    matrix = surrogacy_matrix(accepted(errors.frequency_error_hz, errors.damping_error))
    print("accepted designs per structure:", dict(zip(exploration.names, matrix.accepted_counts.tolist())))
    print("surrogacy (rows surrogate, columns real):", exploration.names)
    print(np.array2string(matrix.confidence, precision=3))
    return matrix


def add_source_arguments(parser: argparse.ArgumentParser) -> None:
    """--data (the ASB data folder) or --rom (the project's beams with virtual measurements)."""
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--data", type=Path, help="folder with asb-reduced-models/ and asb-backbones/")
    source.add_argument("--rom", type=Path, help="the reduction stage's folder (build/rom): virtual measurements")
    parser.add_argument("--configurations", nargs="+", default=["C1", "C2", "C3"], help="ASB configurations")
    parser.add_argument("--designs", type=int, default=2000)


def structures_from(arguments) -> list:
    """The structures the arguments name."""
    if arguments.data is not None:
        return asb_structures(arguments.data, arguments.configurations)
    return virtual_beam_structures(arguments.rom)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_source_arguments(parser)
    parser.add_argument("--out", type=Path, default=Path("results/example-study"))
    arguments = parser.parse_args(argv)
    return run_study(structures_from(arguments), arguments.designs, arguments.out)


if __name__ == "__main__":
    main()
