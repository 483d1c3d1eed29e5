"""Frequency tuning: the joint springs and the LBRB and SBRB geometry tuned to the measured first-bending
frequencies (docs/design.md section 2; paper Table 1).

No drawings of the LBRB and SBRB are public. Their free parameters (``LBRB.body_length``, ``SBRB.spring_height``)
are found so that, with the same joint as the BRB, their first out-of-plane bending frequencies relative to the
BRB's match the measured ratios 80.82/169.48 and 91.96/169.48 (paper Table 1).

The joint is the set of linear springs between the five patch virtual nodes of each half (``fem.springs``):
translational stiffness k (N/m) in x, y, z and rotational k a^2 (N m/rad) about x, y, z with a patch-sized lever
a = 10 mm, the same on every patch pair. The beam is the solid plus the bolt masses (``fem.convergence
.dynamic_matrices``); the springs stand for the whole joint, bolts included. Steps, each a scalar root find on
a monotone frequency:

1. k such that the BRB's first bending is the measured 169.48 Hz (Brent on log10 k; the frequency rises with k).
2. With that k, ``LBRB.body_length`` such that f_LBRB / f_BRB = 80.82/169.48 (secant; remeshing each step).
3. With that k, ``SBRB.spring_height`` such that f_SBRB / f_BRB = 91.96/169.48 (secant; remeshing each step).

Result on the default mesh (130k DOF for the BRB): k = 3.657e8 N/m (k a^2 = 3.657e4 N m/rad), 13.5 % below the
tied BRB's 195.8 Hz; LBRB.body_length = 0.4856 m (80.83 Hz), SBRB.spring_height = 4.874 mm (91.97 Hz). The
values move by 0.3 % (LBRB) and 1 % (SBRB) from a mesh twice as coarse to the default one.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.optimize import brentq
from tqdm import tqdm

from geometry.beam_mesh import read_beam_mesh
from geometry.beams import make_beam
from geometry.parameters import BEAMS, BeamParameters, MeshParameters
from pipeline.files import check_output_folder, write_json
from pipeline.published import TABLE1

from .bolts import Bolt
from .convergence import N_MODES, check_mesh_factor, dynamic_matrices, first_bending
from .elasticity import Material
from .solver import natural_modes
from .springs import joint_stiffness, patch_couplings

#: Measured low-amplitude first-bending frequencies, Hz (paper Table 1, ``pipeline.published.TABLE1``).
MEASURED_HZ = {beam: row.frequency_hz for beam, row in TABLE1.items()}
#: The geometry parameter tuned for each modified beam.
TUNED_FIELD = {"LBRB": "body_length", "SBRB": "spring_height"}
ARM = 0.01  # m: rotational springs k a^2, a patch-sized lever on the translational stiffness k
LOG_STIFFNESS_BRACKET = (6.0, 12.0)  # log10 of k in N/m: from a loose joint to near the stiff-spring limit
MESH_FACTOR = 1.0  # tuning mesh: this factor on the default element sizes (see fem.convergence)
STIFFNESS_TOLERANCE = 1e-5  # relative, on log10 k of the BRB's springs
FREQUENCY_TOLERANCE = 1e-4  # relative, on the tuned LBRB and SBRB first bending (the ratios must hold to 1e-2)


def joint_springs(translational: float, arm: float = ARM) -> np.ndarray:
    """Springs (6,) of every patch pair: k_x = k_y = k_z = k (N/m) and k_rx = k_ry = k_rz = k a^2 (N m/rad)."""
    return np.array([translational] * 3 + [translational * arm ** 2] * 3)


@dataclass(frozen=True)
class SpringBeam:
    """A beam ready for joint springs: K of the two free solid halves (n_dof, n_dof) N/m, M of the solid plus the
    bolt masses, kg, and the lower and upper patch couplings (30, n_dof) (``fem.springs.patch_couplings``)."""

    stiffness: sp.csr_matrix
    mass: sp.csr_matrix
    lower: sp.csr_matrix
    upper: sp.csr_matrix


def spring_beam(beam: BeamParameters, sizes: MeshParameters, folder: Path, material: Material = Material(),
                bolt: Bolt = Bolt()) -> SpringBeam:
    """Mesh ``beam`` into ``folder`` (geometry stage, no render) and assemble its ``SpringBeam``."""
    beam_mesh = read_beam_mesh(make_beam(beam, sizes, folder, render=False).with_suffix(".msh"), beam)
    mesh, stiffness, mass = dynamic_matrices(beam_mesh, beam, material, bolt)
    _, lower, upper = patch_couplings(mesh, beam_mesh)
    return SpringBeam(stiffness, mass, lower, upper)


def spring_first_bending(model: SpringBeam, springs: np.ndarray) -> float:
    """First out-of-plane bending frequency, Hz, of the beam joined by ``springs`` (6,) on every patch pair."""
    frequencies, shapes = natural_modes(model.stiffness + joint_stiffness(model.lower, model.upper, springs),
                                        model.mass, N_MODES)
    return float(frequencies[first_bending(frequencies, shapes)])


def tune_stiffness(model: SpringBeam, target_hz: float, arm: float = ARM) -> float:
    """Translational patch stiffness k, N/m, giving first bending ``target_hz`` (step 1; Brent on log10 k).

    Raises ValueError when the target lies outside the frequencies of ``LOG_STIFFNESS_BRACKET``.
    """
    def error(log_stiffness: float) -> float:
        return spring_first_bending(model, joint_springs(10 ** log_stiffness, arm)) / target_hz - 1

    return 10 ** brentq(error, *LOG_STIFFNESS_BRACKET, rtol=STIFFNESS_TOLERANCE)


def secant_root(function, x0: float, x1: float, tolerance: float, max_iterations: int = 20
                ) -> list[tuple[float, float]]:
    """Secant iteration on a scalar function until |function(x)| < tolerance.

    Returns the history of (x, function(x)); its last entry is the root (x0 alone when it already is one).
    Raises RuntimeError after ``max_iterations`` evaluations.
    """
    history = [(x0, function(x0))]
    x = x1
    while abs(history[-1][1]) >= tolerance:
        if len(history) == max_iterations:
            raise RuntimeError(f"secant iteration not converged after {max_iterations} evaluations: {history[-3:]}")
        history.append((x, function(x)))
        (previous, f_previous), (x, f_x) = history[-2:]
        x = x - f_x * (x - previous) / (f_x - f_previous)
    return history


def tune_geometry(beam: BeamParameters, field: str, target_hz: float, springs: np.ndarray,
                       sizes: MeshParameters, material: Material = Material(), bolt: Bolt = Bolt(),
                       step: float = 0.01) -> list[tuple[float, float]]:
    """Find ``beam.<field>`` (m) whose first bending with ``springs`` is ``target_hz`` (steps 2-3).

    Secant iteration (``secant_root``) on f / target - 1 from the current value and ``(1 + step)`` times it,
    remeshing at every trial, to a relative frequency error below ``FREQUENCY_TOLERANCE``.
    Returns the trials as (value m, first bending Hz), the last one the tuned value.
    """
    with tempfile.TemporaryDirectory(prefix="frequency-tuning-") as folder:
        def error(value: float) -> float:
            trial = beam.replace(**{field: float(value)})
            model = spring_beam(trial, sizes, Path(folder) / f"{value:.9g}", material, bolt)
            return spring_first_bending(model, springs) / target_hz - 1

        start = getattr(beam, field)
        history = secant_root(error, start, start * (1 + step), FREQUENCY_TOLERANCE)
    return [(float(value), float(target_hz * (1 + relative))) for value, relative in history]


def tune_frequencies(sizes: MeshParameters, material: Material = Material(), bolt: Bolt = Bolt(),
                     beams: dict[str, BeamParameters] = BEAMS, stiffness: float | None = None, progress: bool = False
                     ) -> dict:
    """Steps 1-3 on meshes of ``sizes``, starting from the current ``beams``; returns the JSON-ready record.

    stiffness: the BRB's translational patch stiffness k, N/m, found before on the same mesh: step 1 is then
    skipped (its frequency is still computed and recorded).

    Record: mesh, material, bolt; springs (translational k N/m, lever a m, the (6,) spring vector); per beam the
    first bending Hz, and for LBRB and SBRB the tuned parameter (m), the ratio to the BRB, the measured
    ratio and the secant trials [(value m, Hz)]; seconds of wall time.
    """
    start = time.perf_counter()
    log = tqdm.write if progress else (lambda line: None)
    with tempfile.TemporaryDirectory(prefix="frequency-tuning-") as folder:
        brb = spring_beam(beams["BRB"], sizes, Path(folder), material, bolt)
        stiffness = tune_stiffness(brb, MEASURED_HZ["BRB"]) if stiffness is None else stiffness
        springs = joint_springs(stiffness)
        brb_hz = spring_first_bending(brb, springs)
    log(f"BRB: k = {stiffness:.6g} N/m, first bending {brb_hz:.3f} Hz")
    record = {"mesh": dataclasses.asdict(sizes), "material": dataclasses.asdict(material),
              "bolt": dataclasses.asdict(bolt),
              "springs": {"translational_n_per_m": stiffness, "arm_m": ARM, "vector": springs.tolist()},
              "BRB": {"first_bending_hz": brb_hz, "measured_hz": MEASURED_HZ["BRB"]}}
    for name, field in TUNED_FIELD.items():
        measured_ratio = MEASURED_HZ[name] / MEASURED_HZ["BRB"]
        trials = tune_geometry(beams[name], field, brb_hz * measured_ratio, springs, sizes, material, bolt)
        value, frequency = trials[-1]
        log(f"{name}: {field} = {value:.6g} m, first bending {frequency:.3f} Hz after {len(trials)} meshes")
        record[name] = {field: value, "first_bending_hz": frequency, "ratio_to_brb": frequency / brb_hz,
                        "measured_ratio": measured_ratio, "measured_hz": MEASURED_HZ[name], "trials": trials}
    record["seconds"] = time.perf_counter() - start
    return record


def tuning_sizes(mesh_factor: float, stiffness: float | None) -> MeshParameters:
    """The tuning meshes' sizes, ``mesh_factor`` times the default ones, after refusing, before any mesh is made,
    inputs that cannot give a tuning: a factor that is not a positive finite scale, or whose element sizes would
    not fit in memory on any of the beams (``geometry.parameters.check_mesh_size``); a ``stiffness`` (N/m) outside
    the bracket step 1 searches (``LOG_STIFFNESS_BRACKET``: the first bending of a stiffness outside it is no
    bending mode of the beams). Raises ValueError naming the option as typed."""
    sizes = check_mesh_factor("--mesh-factor", mesh_factor, BEAMS.values(), MeshParameters())
    low, high = (10 ** bound for bound in LOG_STIFFNESS_BRACKET)
    if stiffness is not None and not low <= stiffness <= high:
        raise ValueError(f"option --stiffness = {stiffness!r}: expected a patch stiffness from {low:g} "
                         f"to {high:g} N/m")
    return sizes


def write_tuning(out: Path, mesh_factor: float = MESH_FACTOR, stiffness: float | None = None,
                 progress: bool = False) -> tuple[Path, dict]:
    """Steps 1-3 (``tune_frequencies``) on meshes of ``mesh_factor`` times the default sizes, the BRB's patch
    stiffness (N/m) given or found in step 1, written to ``<out>/frequency_tuning.json``. The inputs
    (``tuning_sizes``) and the folder ``out`` are checked before any mesh is made. Returns the file's path and
    the record."""
    sizes = tuning_sizes(mesh_factor, stiffness)
    check_output_folder(out)
    record = tune_frequencies(sizes, stiffness=stiffness, progress=progress)
    path = Path(out) / "frequency_tuning.json"
    write_json(path, record)
    return path, record
