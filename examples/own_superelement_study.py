"""Bring your own superelement and measured backbones: a small surrogacy study on them.

The superelements here are the ASB reduced models exported from ABAQUS (``MAT_NULLRED_<conf>.mat``, see
``reduction.superelement.read_asb_superelement`` for the fields it reads); the measurements are their measured
backbones (``ASB_<conf>_20Nm_BB.mat`` with Q, W, Z; any backbone CSV of ``experiment.backbone_files`` works too).

    python examples/own_superelement_study.py ../shared/data --designs 2000 --out results/example-study
"""

import argparse
from pathlib import Path

import numpy as np

from experiment.backbone_files import read_asb_backbone
from study.errors import accepted
from study.exploration import Exploration, Sample, explore
from study.analysis import model_errors
from study.structures import asb_superelement, structure
from study.surrogacy import surrogacy_matrix


def run_study(data: Path, configurations, designs: int, out: Path, client=None):
    """Structures from the files, a study of ``designs`` iwan4 designs (serially, or on a dask ``client``), and
    its surrogacy matrix."""
    structures = []
    for configuration in configurations:
        superelement = asb_superelement(data / "asb-reduced-models" / f"MAT_NULLRED_{configuration}.mat")
        measured = read_asb_backbone(data / "asb-backbones" / f"ASB_{configuration}_20Nm_BB.mat")
        structures.append(structure(f"ASB {configuration}", superelement, measured, 0.0))
        print(structures[-1].mode_choice)
    damping = {"measured": [float(s.target.damping[0]) for s in structures]}
    exploration = Exploration(tuple(structures), ("iwan4",), Sample(n_designs=designs, chunk_size=500), damping)
    explore(exploration, out, client=client)
    errors = model_errors(out, "iwan4", exploration.names, "measured")
    matrix = surrogacy_matrix(accepted(errors.frequency_error_hz, errors.damping_error))
    print("surrogacy (rows surrogate, columns real):", exploration.names)
    print(np.array2string(matrix.confidence, precision=3))
    return matrix


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", type=Path, help="folder with asb-reduced-models/ and asb-backbones/")
    parser.add_argument("--configurations", nargs="+", default=["C1", "C2", "C3"])
    parser.add_argument("--designs", type=int, default=2000)
    parser.add_argument("--out", type=Path, default=Path("results/example-study"))
    arguments = parser.parse_args(argv)
    return run_study(arguments.data, arguments.configurations, arguments.designs, arguments.out)


if __name__ == "__main__":
    main()
