"""The datasets a study runs on, one registry: the Brake-Reuss beams (virtual experiments) and the ASB assembly
(measured). Every other module asks ``dataset(name)``; adding a dataset is one entry of ``DATASETS`` plus its tests.

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

A ``Dataset`` owns its structures' names, the friction models they can carry and those a study runs unless told,
its damping cases and the rule that makes them zeta_0, where its measurements come from (their input files, what
else they depend on, how they are written as backbone CSVs), its superelements' format, and how the pipeline report
names it (its backbones' title, the public measured data its study reads).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from experiment.backbone_files import write_backbone
from experiment.measured_files import read_mode_backbone
from geometry.parameters import BEAM_NAMES
from nonlinear.friction_models import models_for
from nonlinear.joint import BRB_PATCH_GROUPS
from reduction.superelement import ASB_CONFIGURATIONS, StructureError, Superelement, beam_superelement
from study.structures import N_LEVELS, Structure, asb_superelement, structure
from virtual_experiment.hammer_test import virtual_experiments


@dataclass(frozen=True)
class Dataset:
    """One dataset: a set of structures sharing one joint.

    name: as ``[study] dataset`` gives it. structures: the structures' names. models: the friction models they can
    carry; default_models: those a study runs unless told. default_damping_case: the linear damping case the
    analysis uses; damping_rule: how its cases become zeta_0 (``study.errors.DAMPING_RULES``). paper: the paper's
    study (its Table 5 beside the surrogacy matrices, Table 6's ANOVA and the prestress comparison).
    backbone_title: its group's title in the pipeline report's backbone figure. measured_data: the public measured
    data its study reads, where it reads any (the pipeline report names it where the study did not run).

    Each function takes the study's inputs ``paths`` (``study.workflow.Paths``: ``rom`` and ``data`` folders, the
    paper's ``tables``, the ``measurements`` folder): ``sources(paths)``, the files its measurements are made of;
    ``inputs(paths)``, what else they depend on (JSON-ready, recorded for the cache); ``write_measurements(paths)``,
    its backbones to fit as backbone CSVs in ``paths.measurements``; ``superelement(paths, name, prestress)``, a
    structure's superelement; ``damping_cases(paths, structures)``, case name -> zeta_0 of each structure.
    """

    name: str
    structures: tuple[str, ...]
    models: tuple[str, ...]
    default_models: tuple[str, ...]
    default_damping_case: str
    damping_rule: str
    paper: bool
    sources: Callable[..., list[Path]]
    inputs: Callable[..., dict]
    write_measurements: Callable[..., None]
    superelement: Callable[..., Superelement]
    damping_cases: Callable[..., dict[str, list[float]]]
    backbone_title: str
    measured_data: str | None = None


def measurement_path(folder: Path, name: str) -> Path:
    return Path(folder) / f"{name.replace(' ', '_')}.csv"


def asb_backbone_path(data_folder: Path, configuration: str) -> Path:
    return Path(data_folder) / "asb-backbones" / f"ASB_{configuration}_20Nm_BB.mat"


def write_asb_measurements(data_folder: Path, folder: Path) -> list[Path]:
    """The ASB's measured backbones (``asb-backbones/ASB_<conf>_20Nm_BB.mat``) in the backbone CSV format."""
    paths = []
    for configuration in ASB_CONFIGURATIONS:
        source = asb_backbone_path(data_folder, configuration)
        if not source.exists():
            raise StructureError(f"{source}: missing (the ASB measurements: surrogacy data fetch downloads them)")
        measured = read_mode_backbone(source)
        paths.append(measurement_path(folder, measured.structure))
        write_backbone(measured, paths[-1])
    return paths


BEAMS = Dataset(
    "beams", BEAM_NAMES, models_for(max(BRB_PATCH_GROUPS) + 1), models_for(max(BRB_PATCH_GROUPS) + 1, in_paper=True),
    "BRB", "added", True,
    sources=lambda paths: [paths.rom / f"{beam}.npz" for beam in BEAM_NAMES],
    inputs=lambda paths: {
        "table1": {beam: [row.frequency_hz, row.damping] for beam, row in paths.tables.table1.items()},
        "table3": {name: list(limits) for name, limits in paths.tables.table3.items()}},
    write_measurements=lambda paths: virtual_experiments(paths.rom, paths.measurements, paths.tables.table1,
                                                         paths.tables.table3),
    superelement=lambda paths, name, prestress: beam_superelement(paths.rom / f"{name}.npz", prestress),
    damping_cases=lambda paths, structures: {beam: [paths.tables.table1[beam].damping] * len(structures)
                                             for beam in BEAM_NAMES},
    backbone_title="beams: VIRTUAL experiments")
"""The beams: the paper's four models by default (Table 5 and the ANOVA of Table 6 compare) of those their three
patch groups can carry."""
ASB = Dataset(
    "asb", tuple(f"ASB {configuration}" for configuration in ASB_CONFIGURATIONS), models_for(1), models_for(1),
    "measured", "outside_joint", False,
    sources=lambda paths: [asb_backbone_path(paths.data, configuration) for configuration in ASB_CONFIGURATIONS],
    inputs=lambda paths: {},
    write_measurements=lambda paths: write_asb_measurements(paths.data, paths.measurements),
    superelement=lambda paths, name, prestress: asb_superelement(
        paths.data / "asb-reduced-models" / f"MAT_NULLRED_{name.removeprefix('ASB ')}.mat"),
    damping_cases=lambda paths, structures: {"measured": [float(s.measurement.damping[0]) for s in structures]},
    backbone_title="ASB: measured", measured_data="the measured ASB backbones and reduced models")
"""The ASB: every model its single patch group can carry (every patch in one group,
``study.structures.asb_superelement``), all of them by default; its reduced models as their files give them."""
DATASETS = {dataset.name: dataset for dataset in (BEAMS, ASB)}
"""Every dataset by name."""
DATASET_NAMES = tuple(DATASETS)


def dataset(name: str) -> Dataset:
    """The registry's dataset of that name; StructureError listing the datasets otherwise."""
    try:
        return DATASETS[name]
    except (KeyError, TypeError):
        raise StructureError(f"dataset {name!r} is not one of {DATASET_NAMES}") from None


def dataset_structures(name: str, paths, n_levels: int = N_LEVELS, prestress: bool = True) -> list[Structure]:
    """The dataset's structures from the measurement files in ``paths.measurements``; linear damping 0 (the cases
    of ``Dataset.damping_cases`` are applied in the errors). prestress: the beams' superelements with the preload's
    stress stiffness (``reduction.superelement.beam_superelement``); the ASB's are as their files give them."""
    chosen = dataset(name)
    structures = []
    for structure_name in chosen.structures:
        path = measurement_path(paths.measurements, structure_name)
        if not path.exists():
            raise StructureError(f"{path}: missing measurement of {structure_name} (run the measurements step first)")
        structures.append(structure(structure_name, chosen.superelement(paths, structure_name, prestress),
                                    read_mode_backbone(path), 0.0, n_levels, str(path)))
    return structures
