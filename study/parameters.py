"""A study's configuration: the sections of ``surrogacy study --config`` / ``--set`` ([study], [sample],
[acceptance], [pareto], [compute]), each a frozen dataclass that checks its fields (ValueError naming the field)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from nonlinear.compute_devices import DEVICES
from study.datasets import DATASET_NAMES, dataset
from study.errors import DAMPING_TOLERANCE, FREQUENCY_TOLERANCE_HZ
from study.exploration import Sample
from study.structures import N_LEVELS


@dataclass(frozen=True)
class StudyParameters:
    """[study]: dataset (``study.datasets.DATASETS``), friction models (default: the dataset's default_models),
    levels per structure, and whether the beams' superelements carry the preload's stress stiffness (``prestress``, default
    true: K_A + K_bolt; false: the unstressed halves K; ``reduction.superelement.beam_superelement``). The ASB's
    reduced models are used as their files give them whatever ``prestress`` says."""

    dataset: str = "beams"
    models: tuple[str, ...] = ()
    n_levels: int = N_LEVELS
    prestress: bool = True

    def __post_init__(self):
        if self.dataset not in DATASET_NAMES:
            raise ValueError(f"field 'dataset' = {self.dataset!r}: expected one of {DATASET_NAMES}")
        available = dataset(self.dataset).models
        unknown = [m for m in self.models if m not in available]
        if unknown:
            raise ValueError(f"field 'models': {unknown} not available for dataset {self.dataset!r}; expected some "
                             f"of {available}")
        if self.n_levels < 3:
            raise ValueError(f"field 'n_levels' = {self.n_levels}: expected at least 3")
        if not isinstance(self.prestress, bool):
            raise ValueError(f"field 'prestress' = {self.prestress!r}: expected true or false")

    @property
    def friction_models(self) -> tuple[str, ...]:
        return self.models or dataset(self.dataset).default_models


@dataclass(frozen=True)
class AcceptanceParameters:
    """[acceptance]: L-infinity bounds of paper section 4.4."""

    frequency_tolerance_hz: float = FREQUENCY_TOLERANCE_HZ
    damping_tolerance: float = DAMPING_TOLERANCE

    def __post_init__(self):
        for name, value in asdict(self).items():
            if not value > 0.0:
                raise ValueError(f"field '{name}' = {value}: expected a positive bound")


@dataclass(frozen=True)
class ParetoParameters:
    """[pareto]: NSGA-II generations and population, seeded from the sample's front; representative
    designs per structure."""

    generations: int = 20
    population: int = 48
    representatives: int = 3

    def __post_init__(self):
        for name, value in asdict(self).items():
            if value < 1:
                raise ValueError(f"field '{name}' = {value}: expected at least 1")


@dataclass(frozen=True)
class ComputeParameters:
    """[compute]: where the stuck modes and QSMA levels of the study's designs are solved (``device``: "cpu", the
    compiled CPU kernels, or "cuda", the same kernels on a CUDA GPU; ``nonlinear.compute_devices``). The explore
    and analyse steps use it, and so do ``surrogacy fit`` and ``surrogacy confidence`` unless their ``--device``
    names another; the results agree to round-off across devices, so it is not part of the study key."""

    device: str = "cpu"

    def __post_init__(self):
        if self.device not in DEVICES:
            raise ValueError(f"field 'device' = {self.device!r}: expected one of {DEVICES}")


def defaults() -> dict:
    """Each section's default values: section name -> dataclass."""
    return {"study": StudyParameters(), "sample": Sample(), "acceptance": AcceptanceParameters(),
            "pareto": ParetoParameters(), "compute": ComputeParameters()}
