"""The two datasets a study runs on: the Brake-Reuss beams (virtual experiments) and the ASB assembly (measured).

Each dataset is a set of structures sharing one joint. Their measured backbones are first written in the one
documented backbone format (``experiment.backbone_files``, ``<study>/measurements/<structure>.csv``), and the
study reads only those files, whatever the source:

- ``beams``: BRB, LBRB, SBRB on the project's superelements (``build/rom/<beam>.npz``, by default the prestressed
  halves K_A + K_bolt, with ``prestress`` false the unstressed K; ``reduction.superelement.beam_superelement``),
  measured by the virtual experiments of ``virtual_experiment.hammer_test`` (labelled virtual). Linear damping
  cases (paper Table 6's "linearized zeta" factor): the BRB's, the LBRB's and the SBRB's Table 1 value, each
  applied to every beam; the paper's default is the BRB's. Added to the joint's damping (``study.errors`` rule
  "added"): the virtual experiments add it so.
- ``asb``: the six configurations C1, C2, C3, C4, C4a, CD1 of the real assembly (ABAQUS reduced models and
  measured backbones; CD2 has no reduced model). Every patch in one group, so that one design
  is the same joint in all six (``study.structures.asb_superelement``). One linear damping case, ``measured``:
  each configuration's damping at its lowest measured level, less each design's own joint damping there
  (``study.errors`` rule "outside_joint": the measured damping already holds the joint's). The middle-stuck model
  needs a middle patch and is not defined on the ASB's single group: the ASB study runs Jenkins, both Iwan models
  and the stuck core.
"""

from __future__ import annotations

from pathlib import Path

from experiment.backbone_files import write_backbone
from experiment.measured_files import read_mode_backbone
from geometry.parameters import BEAM_NAMES
from nonlinear.friction_models import models_for
from nonlinear.joint import BRB_PATCH_GROUPS
from reduction.superelement import ASB_CONFIGURATIONS, StructureError, beam_superelement
from study.structures import N_LEVELS, Structure, asb_superelement, structure

DATASETS = ("beams", "asb")
DATASET_MODELS = {"beams": models_for(max(BRB_PATCH_GROUPS) + 1), "asb": models_for(1)}
"""The friction models each dataset's structures can carry: the beams' three patch groups, the ASB's one (every
patch in one group, ``study.structures.asb_superelement``)."""
DEFAULT_MODELS = {"beams": models_for(max(BRB_PATCH_GROUPS) + 1, in_paper=True), "asb": DATASET_MODELS["asb"]}
"""The models a study runs unless told: the paper's four on the beams (Table 5 and the ANOVA of Table 6 compare),
every model the ASB can carry (its single group rules out the middle-stuck one)."""
DEFAULT_DAMPING_CASE = {"beams": "BRB", "asb": "measured"}
DAMPING_RULE = {"beams": "added", "asb": "outside_joint"}
"""How each dataset's damping cases become zeta_0 (``study.errors.DAMPING_RULES``, module docstring)."""


def measurement_path(folder: Path, name: str) -> Path:
    return Path(folder) / f"{name.replace(' ', '_')}.csv"


def write_asb_measurements(data_folder: Path, folder: Path) -> list[Path]:
    """The ASB's measured backbones (``asb-backbones/ASB_<conf>_20Nm_BB.mat``) in the backbone CSV format."""
    paths = []
    for configuration in ASB_CONFIGURATIONS:
        source = Path(data_folder) / "asb-backbones" / f"ASB_{configuration}_20Nm_BB.mat"
        if not source.exists():
            raise StructureError(f"{source}: missing (the ASB measurements: surrogacy data fetch downloads them)")
        measured = read_mode_backbone(source)
        paths.append(measurement_path(folder, measured.structure))
        write_backbone(measured, paths[-1])
    return paths


def structure_names(dataset: str) -> list[str]:
    if dataset not in DATASETS:
        raise StructureError(f"dataset {dataset!r} is not one of {DATASETS}")
    return list(BEAM_NAMES) if dataset == "beams" else [f"ASB {c}" for c in ASB_CONFIGURATIONS]


def dataset_structures(dataset: str, measurements: Path, rom_folder: Path, data_folder: Path,
                       n_levels: int = N_LEVELS, prestress: bool = True) -> list[Structure]:
    """The dataset's structures from the measurement files in ``measurements``; linear damping 0 (the cases
    of :func:`damping_cases` are applied in the errors). prestress: the beams' superelements with the preload's
    stress stiffness (``reduction.superelement.beam_superelement``); the ASB's are as their files give them."""
    structures = []
    for name in structure_names(dataset):
        path = measurement_path(measurements, name)
        if not path.exists():
            raise StructureError(f"{path}: missing measurement of {name} (run the measurements step first)")
        measured = read_mode_backbone(path)
        if dataset == "beams":
            superelement = beam_superelement(Path(rom_folder) / f"{name}.npz", prestress)
        else:
            configuration = name.removeprefix("ASB ")
            superelement = asb_superelement(Path(data_folder) / "asb-reduced-models" / f"MAT_NULLRED_{configuration}.mat")
        structures.append(structure(name, superelement, measured, 0.0, n_levels, str(path)))
    return structures


def damping_cases(dataset: str, structures: list[Structure], table1: dict | None = None) -> dict[str, list[float]]:
    """Linear damping cases (module docstring): case name -> zeta_0 of each structure. table1: paper Table 1
    (``pipeline.published.TABLE1``: beam -> LowAmplitude), for the beams."""
    if dataset == "beams":
        return {beam: [table1[beam].damping] * len(structures) for beam in BEAM_NAMES}
    return {"measured": [float(s.measurement.damping[0]) for s in structures]}
