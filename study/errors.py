"""Errors of designs against a structure's measurement (paper Eqs. 26-27) and their acceptance.

For each design, QSMA gives the model's natural frequency f_i (Hz) and joint damping zeta_J,i at the structure's
levels q_i (amplitude control, ``nonlinear.qsma_vectorised``), and

    e_f = max_i |f_i - f_m,i|   (Hz)            e_zeta = max_i |zeta_J,i + zeta_0 - zeta_m,i|   (-)

with f_m, zeta_m the measurement at the levels (``study.structures.BackboneLevels``) and zeta_0 the linear damping of
the structure's other mechanisms (paper Eq. 25). zeta_0 enters only as an offset, so the damping error is
formed for several zeta_0 at once from one QSMA solve. Where zeta_0 comes from (``DAMPING_RULES``):

    added          zeta_0 = the case's value (paper Eq. 25, as the paper did): right where the value is the
                   damping outside the joint, as in the virtual experiments, which add it to the joint's;
    outside_joint  zeta_0 = max(zeta_c - zeta_J,1, 0): the case's value zeta_c is the damping the structure shows
                   at its lowest measured level, which already holds the joint's own microslip damping zeta_J,1
                   there; adding zeta_c to the joint's damping would count that twice (on the measured ASB CD1
                   the fits that get the frequency right put the damping high by a nearly constant offset). The curves never leave the chunk being evaluated: only
the two errors per design, the convergence flag and its reason are kept (the 30-level curves of the paper's
6 x 10^7 evaluations would take tens of GB).

A design with any level not converged gets NaN errors, converged = False and the first failing level's reason;
it is never accepted and never dropped.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from nonlinear.condensation import ModalSplit, StuckModeCache
from nonlinear.qsma_vectorised import qsma_designs
from study.structures import Structure

FREQUENCY_TOLERANCE_HZ = 2.0  # paper section 4.4 acceptance, L-infinity
DAMPING_TOLERANCE = 5e-3
DAMPING_RULES = ("added", "outside_joint")
"""How a damping case's value becomes each design's zeta_0 (module docstring)."""


class DesignErrors(NamedTuple):
    """Errors of n designs against one structure.

    frequency_error_hz: (n,) e_f (Hz); damping_error: (n, n_cases) e_zeta for each zeta_0 case; converged:
    (n,) bool; reason: (n,) str, '' when converged; stuck_frequency_hz: (n,) the tracked mode's low-amplitude
    frequency (Hz).
    """

    frequency_error_hz: np.ndarray
    damping_error: np.ndarray
    converged: np.ndarray
    reason: np.ndarray
    stuck_frequency_hz: np.ndarray


def structure_damping(joint_damping, linear_damping, rule: str = "added") -> np.ndarray:
    """zeta_0 (n, n_cases) of each design for each damping case's value (n_cases,) by ``rule`` (module
    docstring); joint_damping: (n, levels) the joint's own damping ratio, lowest level first."""
    if rule not in DAMPING_RULES:
        raise ValueError(f"damping rule {rule!r}: expected one of {DAMPING_RULES}")
    values = np.asarray(linear_damping, dtype=float)[None, :]
    if rule == "added":
        return np.repeat(values, len(joint_damping), axis=0)
    return np.maximum(values - np.asarray(joint_damping)[:, :1], 0.0)


def curve_errors(frequency_hz, joint_damping, target_frequency_hz, target_damping, linear_damping,
                 rule: str = "added"):
    """L-infinity errors (Eqs. 26-27) of model curves (n, levels) against a measurement (levels,), for each
    damping case's value in ``linear_damping`` (n_cases,) made zeta_0 by ``rule``: returns e_f (n,) Hz and
    e_zeta (n, n_cases)."""
    frequency_error = np.max(np.abs(frequency_hz - target_frequency_hz), axis=-1)
    offsets = structure_damping(joint_damping, linear_damping, rule)
    misfit = (joint_damping - target_damping)[:, None, :] + offsets[:, :, None]
    return frequency_error, np.max(np.abs(misfit), axis=-1)


def design_errors(structure: Structure, model: str, designs, linear_damping, split: ModalSplit | None = None,
                  stuck_group: int | None = None, rule: str = "added", stuck: StuckModeCache | None = None,
                  device: str = "cpu") -> DesignErrors:
    """QSMA of ``designs`` (n, n_parameters) on ``structure`` at its levels and their errors for each damping
    case's value in ``linear_damping`` (n_cases,) made zeta_0 by ``rule``. split:
    ``nonlinear.condensation.modal_split(structure.space)``, once per structure; stuck: the structure's stuck
    modes shared with other calls; device: where the levels are solved (both ``nonlinear.qsma_vectorised
    .qsma_designs``)."""
    measurement = structure.measurement
    result = qsma_designs(structure.space, model, designs, amplitudes=measurement.amplitude, linear_damping=0.0,
                          split=split, stuck_group=stuck_group, stuck=stuck, device=device)
    converged = result.converged.all(axis=1)
    with np.errstate(invalid="ignore"):
        frequency_error, damping_error = curve_errors(result.frequency / (2.0 * np.pi), result.damping,
                                                      measurement.frequency_hz, measurement.damping, linear_damping,
                                                      rule)
    frequency_error[~converged] = np.nan
    damping_error[~converged] = np.nan
    first_failure = np.argmin(result.converged, axis=1)
    reason = np.where(converged, "", result.reason[np.arange(len(converged)), first_failure]).astype(str)
    return DesignErrors(frequency_error, damping_error, converged, reason, result.stuck_frequency / (2.0 * np.pi))


def accepted(frequency_error_hz, damping_error, frequency_tolerance_hz: float = FREQUENCY_TOLERANCE_HZ,
             damping_tolerance: float = DAMPING_TOLERANCE) -> np.ndarray:
    """Acceptance (paper section 4.4): both L-infinity errors within their bounds; NaN (not converged) is never
    accepted. Arrays of any matching shape."""
    with np.errstate(invalid="ignore"):
        return (np.asarray(frequency_error_hz) <= frequency_tolerance_hz) & (np.asarray(damping_error)
                                                                              <= damping_tolerance)


def scaled_misfit(frequency_error_hz, damping_error, frequency_tolerance_hz: float = FREQUENCY_TOLERANCE_HZ,
                  damping_tolerance: float = DAMPING_TOLERANCE) -> np.ndarray:
    """g = max(e_f / f_b, e_zeta / zeta_b): each L-infinity error in its acceptance bound, so that a design is
    accepted (``accepted``) exactly where g <= 1 and the region {g <= b} is the acceptance box with both bounds
    scaled by b; inf where either error is NaN (not converged). Arrays of any matching shape."""
    misfit = np.maximum(np.asarray(frequency_error_hz, dtype=float) / frequency_tolerance_hz,
                       np.asarray(damping_error, dtype=float) / damping_tolerance)
    return np.where(np.isnan(misfit), np.inf, misfit)
