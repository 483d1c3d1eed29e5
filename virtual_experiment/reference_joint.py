"""The reference joint of the beams' virtual experiments, tuned to the paper's Table 1 and checked against its
Table 3 (``pipeline.published``).

Reference joint (:func:`reference_joint`). A uniform interface over the lap: every patch pair carries stiffness
and slip force in proportion to its area A_p (Table 3's parameters are per patch pair, N and N/m):

    K_T,p = k_t A_p,   K_z,p = (2 - nu) / (2 (1 - nu)) k_t A_p (Mindlin's normal-to-tangential ratio, nu = 0.29),
    F_S,p = mu p_c A_p,   p_c = 3 x 11,580 N / sum_p A_p (the three bolts' preload spread over the lap),

with mu = 0.3, the Iwan exponent chi = -0.5 (dissipation per cycle ~ amplitude^2.5, within the 2-3 measured on
bolted laps) and beta = 0.1 (a small macroslip spike). The tangential contact stiffness k_t (N/m per m^2) is the
root (Brent, on log10 k_t) at which the BRB's stuck first bending frequency is the measured 169.48 Hz: k_t = 1.4e12
N/m^3 (K_T 5.4e8 and 1.0e9 N/m per patch pair); the superelement with its patches tied gives 182.84 Hz, so the
joint is compliant. F_S only sets the amplitude scale (all patches share F_S / K_T): F_S 1,376 and 2,557 N. The
same joint puts the LBRB at 80.79 Hz and the SBRB at 91.94 Hz (Table 1: 80.82 and 91.96). Over the BRB's
virtual backbone (1.6e-5 to 1.9e-4 m kg^0.5) the frequency falls 1.2 % and the damping rises from 1.5 to 4 times
Table 1's: the paper's "approximately 2 %" and "large increase" (section 3).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from fem.bolts import BOLT_PRELOAD
from nonlinear.condensation import JointSpace, joint_space
from nonlinear.qsma_vectorised import qsma_designs
from pipeline.published import TABLE3
from reduction.superelement import beam_superelement, target_mode

MODEL = "iwan4"
POISSON_RATIO = 0.29  # paper section 4.1
N_BOLTS = 3
FRICTION_COEFFICIENT = 0.3  # mu of F_S = mu p_c A_p
CHI = -0.5  # Iwan exponent: dissipation per cycle ~ amplitude^(3 + chi)
BETA = 0.1  # Iwan macroslip spike relative to the power-law part
LOW_AMPLITUDE = 1e-9  # m kg^0.5: QSMA level called for the stuck eigenproblem (its frequency does not depend on it)


def outside_limits(design, names: list[str], limits: dict[str, tuple[float, float, bool]] = TABLE3) -> list[str]:
    """The design's entries outside Table 3's limits (``pipeline.published.TABLE3``: parameter -> (minimum,
    maximum, logarithmic)), as 'name = value' strings (empty: all inside)."""
    outside = []
    for name, value in zip(names, np.asarray(design, dtype=float)):
        low, high, _ = limits[name.split("[")[0]]
        if not low <= value <= high:
            outside.append(f"{name} = {value:g} (limits {low:g} to {high:g})")
    return outside


def beam_space(rom_path: Path, frequency_hz: float) -> JointSpace:
    """Joint space of a beam's superelement (``build/rom/<beam>.npz``, the prestressed halves K_A + K_bolt, the
    study's default, :func:`reduction.superelement.beam_superelement`) tracking the mode a measurement at
    ``frequency_hz`` saw
    (:func:`reduction.superelement.target_mode`: its tied first bending mode for the three beams)."""
    superelement = beam_superelement(Path(rom_path))
    _, shape, _ = target_mode(superelement, frequency_hz)
    return joint_space(superelement, reference_mode=shape)


def group_areas(space: JointSpace) -> np.ndarray:
    """Area (m^2) of one patch of each parameter group, (n_groups,) (the patches of a group are mirror images)."""
    groups = np.asarray(space.superelement.patch_groups)
    return np.array([space.superelement.patch_areas[np.flatnonzero(groups == g)[0]] for g in range(groups.max() + 1)])


def contact_pressure(space: JointSpace, bolt_preload: float = BOLT_PRELOAD, n_bolts: int = N_BOLTS) -> float:
    """Mean clamping pressure over the lap (Pa): the bolts' preload (N each) over the patches' total area."""
    return n_bolts * bolt_preload / float(np.sum(space.superelement.patch_areas))


def uniform_interface(areas, tangential_stiffness: float, slip_traction: float, chi: float = CHI,
                      beta: float = BETA, poisson_ratio: float = POISSON_RATIO) -> np.ndarray:
    """iwan4 design (5 n_groups,) of a uniform interface, groups in order (F_S, K_T, chi, beta, K_z).

    areas: (n_groups,) patch area per group, m^2. tangential_stiffness: k_t, N/m per m^2 of contact.
    slip_traction: mu p_c, Pa. Per patch pair K_T = k_t A, K_z = (2 - nu) / (2 (1 - nu)) K_T (Mindlin's ratio of
    normal to tangential contact stiffness), F_S = mu p_c A; chi, beta common.
    """
    areas = np.asarray(areas, dtype=float)
    stiffness = tangential_stiffness * areas
    normal = (2.0 - poisson_ratio) / (2.0 * (1.0 - poisson_ratio)) * stiffness
    return np.column_stack([slip_traction * areas, stiffness, np.full_like(areas, chi), np.full_like(areas, beta),
                            normal]).ravel()


def stuck_frequency_hz(space: JointSpace, design, model: str = MODEL) -> float:
    """The tracked mode's stuck (low-amplitude) natural frequency (Hz) of one design, from QSMA's stuck
    eigenproblem (``nonlinear.qsma_vectorised.qsma_designs``)."""
    result = qsma_designs(space, model, np.asarray(design, dtype=float)[None, :], amplitudes=[LOW_AMPLITUDE])
    return float(result.stuck_frequency[0]) / (2.0 * np.pi)


def reference_joint(space: JointSpace, frequency_hz: float, friction_coefficient: float = FRICTION_COEFFICIENT,
                    chi: float = CHI, beta: float = BETA, log_stiffness_bracket=(10.0, 14.0)) -> np.ndarray:
    """The reference joint (module docstring): the uniform interface whose tracked stuck frequency in ``space``
    is ``frequency_hz`` (the BRB's measured 169.48 Hz), iwan4 design (15,) for the BRB's three groups.

    log_stiffness_bracket: log10 of k_t (N/m per m^2) bracketing the root; the stuck frequency increases with k_t
    towards the tied one (raises ValueError when ``frequency_hz`` is outside the bracket's frequencies). Below
    1e10 the prestressed BRB family's interface is too soft to carry the clamp's softening of the halves' relative
    twist (unstable at 1e9, stable at 3e9 N/m per m^2; docs/design.md section 4).
    """
    areas = group_areas(space)
    traction = friction_coefficient * contact_pressure(space)

    def frequency_error(log_stiffness):
        return stuck_frequency_hz(space, uniform_interface(areas, 10.0 ** log_stiffness, traction, chi, beta)) \
            - frequency_hz

    log_stiffness = brentq(frequency_error, *log_stiffness_bracket, xtol=1e-12, rtol=1e-14)
    return uniform_interface(areas, 10.0 ** log_stiffness, traction, chi, beta)
