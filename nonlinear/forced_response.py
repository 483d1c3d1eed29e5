"""The periodic response of the jointed structure to a harmonic force at a drive point, by harmonic balance in its
condensed joint space (``nonlinear.harmonic_balance``), continued in the forcing frequency by pseudo-arclength
through folds: the stepped-sine form of measured data.

Equations. The stuck structure's modes (mu_j, v_j; identity mass), c_j their tangential joint motion, each with
viscous modal damping zeta_j (the linear damping of the structure's other mechanisms), loaded by a force
F cos(Omega t) at a drive point whose displacement is d^T eta (d (n_modes,) the drive point's row in the
structure's coordinates eta, so that the force is d F cos(Omega t) there, N):

    p_j'' + 2 zeta_j omega_j p_j' + mu_j p_j = c_j^T g(r_t) + a_j F cos(Omega t),   a_j = d^T v_j,
    omega_j = sqrt(mu_j),   r_t = sum_j c_j p_j,

g the slip deficit of the friction elements (N). Harmonic balance: r_t(tau) = U_0 + sum_k (U_ak cos k tau +
U_bk sin k tau), tau = Omega t, k = 1..H; the Fourier-Galerkin projection of each modal equation on 1, cos k tau,
sin k tau gives, in complex form (R_k = U_ak - i U_bk),

    P_jk = (c_j^T G_k + a_j F [k = 1]) / (d_jk - i e_jk),   d_jk = mu_j - (k Omega)^2,
    e_jk = -2 zeta_j omega_j k Omega,

the xi_j = -2 zeta_j omega_j of ``nonlinear.harmonic_balance``'s convention. Summed with c_j, the residual in the
joint harmonics U (2H+1, n_t) is

    R(U, Omega) = U - H(Omega) G(U) - U_F(Omega) - U_s = 0,

H the stuck structure's dynamic compliance (``compliance_operator``), U_F the joint motion the force alone gives
the stuck structure (harmonic 1 only: U_a1 - i U_b1 = sum_j c_j a_j F / (d_j1 - i e_j1)) and U_s the static
step's (harmonic 0: C load, C the static compliance). AFT: G(U) = P g(E U), the joint motion sampled at N points
per period, every element stepped period after period from the static state until its hysteresis is periodic,
and the last period projected back (``slip_deficit_harmonics``); dR/dU = I - H dG/dU with the analytic Jacobian of
the hysteresis, dR/dOmega = -(dH/dOmega) G - dU_F/dOmega.

Continuation: unknowns y = U / s, s the largest joint motion of the stuck structure under the force at the asked
frequencies and its natural frequencies between them; parameter Omega / omega_0 (omega_0 the stuck target mode's);
Newton's method from the stuck structure's response at the first frequency, then pseudo-arclength
(``pseudo_arclength``, its tangent turning by at most MAX_TURN a step but at a corner such as the onset of slip)
with every further asked frequency and every stuck natural frequency between them a point of the branch. Where
the branch folds, its points follow the fold back and forth; the points at the asked frequencies are those an
upward stepped sine reaches (jumping at the fold). Stability is not assessed.

Units: Omega rad/s, F N, displacements m, modal coordinates m kg^0.5.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from nonlinear.condensation import JointSpace
from nonlinear.epmc import SAMPLES, joint_system
from nonlinear.harmonic_balance import (MAX_PERIODS, JointHarmonics, JointSystem, compliance_operator,
                                        dynamic_compliance, element_jacobian, harmonic_count, modal_harmonics,
                                        modal_receptance, newton, pseudo_arclength)

RESIDUAL_TOLERANCE = 1e-10  # a converged point's largest residual, relative to its largest joint motion
MAX_TURN = 0.3  # rad: the continuation's largest turn of the branch's tangent in one step (``pseudo_arclength``)


def viscous_damping(system: JointSystem, linear_damping) -> np.ndarray:
    """xi_j = -2 zeta_j sqrt(mu_j) (n_modes,) rad/s: viscous modal damping zeta (one for every stuck mode, or
    (n_modes,)) in ``nonlinear.harmonic_balance``'s convention p'' - xi p' + mu p."""
    return -2.0 * np.broadcast_to(np.asarray(linear_damping, dtype=float), system.eigenvalues.shape) \
        * np.sqrt(np.abs(system.eigenvalues))


def fundamental_motion(system: JointSystem, excitation: np.ndarray, real: np.ndarray,
                       imaginary: np.ndarray) -> np.ndarray:
    """(2, n_t) cosine and sine parts of sum_j c_j f_j (real_j - i imaginary_j): the stuck structure's joint
    motion (m) under the modal forces f (n_modes,) N kg^-0.5 with the receptances' harmonic-1 row (n_modes,)
    (``modal_receptance``), or its derivative with the receptances' derivative."""
    c = system.joint_shapes
    return np.stack([c.T @ (excitation * real), -c.T @ (excitation * imaginary)])


class ForcedEquations(JointHarmonics):
    """The forced harmonic-balance residual (module docstring) of one JointSystem at H >= 1 harmonics and N samples
    under the modal force amplitudes ``excitation`` (n_modes,) N kg^-0.5, with the viscous damping xi (n_modes,)
    rad/s (``viscous_damping``), about the static state under ``load`` (n_modes,) N kg^-0.5 (default none: the
    reduced models are linearised about their preloaded equilibrium). frequencies: the continuation's Omega
    (rad/s, ``band_frequencies``), which set the unknowns' scale s."""

    def __init__(self, system: JointSystem, excitation: np.ndarray, xi: np.ndarray, harmonics: int,
                 frequencies, samples: int = SAMPLES, load=None):
        if harmonics < 1:
            raise ValueError(f"a forced response needs at least one harmonic; got {harmonics}")
        super().__init__(system, harmonics, samples, load)
        self.excitation, self.xi = excitation, xi
        self.scale = max(float(np.abs(self.stuck_motion(omega)).max()) for omega in frequencies) or 1.0

    def stuck_motion(self, omega: float, derivative: bool = False) -> np.ndarray:
        """(2, n_t) U_a1, U_b1 of U_F at Omega (m), or with ``derivative`` their derivative in Omega (m s/rad)."""
        receptance = modal_receptance(self.system, omega, self.xi, 1, resonant_target=True)
        real, imaginary = (receptance.real_omega, receptance.imaginary_omega) if derivative else \
            (receptance.real, receptance.imaginary)
        return fundamental_motion(self.system, self.excitation, real[1], imaginary[1])

    def harmonic_rows(self, static: np.ndarray, fundamental: np.ndarray) -> np.ndarray:
        """(size,) the unknowns' layout (2H+1, n_t) raveled, holding harmonic 0 ``static`` (n_t,) and harmonic 1
        ``fundamental`` (2, n_t), the other harmonics zero."""
        rows = np.zeros((harmonic_count(self.harmonics), self.n_t))
        rows[0], rows[1:3] = static, fundamental
        return rows.ravel()

    def __call__(self, y: np.ndarray, frequency_ratio: float):
        """(R, dR/dy, dR/d(Omega / omega_0)) at scaled unknowns y = U / s (size,) and Omega / omega_0."""
        omega, s = self.omega_0 * frequency_ratio, self.scale
        aft = self.deficit(s * y.reshape(-1, self.n_t))
        g = aft.harmonics.ravel() / s
        compliance = dynamic_compliance(self.system, omega, self.xi, self.harmonics, resonant_target=True)
        operator = compliance_operator(compliance.real, compliance.imaginary)
        residual = y - operator @ g - self.harmonic_rows(self.static_linear, self.stuck_motion(omega)) / s
        jacobian = np.eye(self.size) - operator @ element_jacobian(aft.jacobian)
        derivative = -self.omega_0 * (compliance_operator(compliance.real_omega, compliance.imaginary_omega) @ g
                                      + self.harmonic_rows(0.0, self.stuck_motion(omega, derivative=True)) / s)
        return residual, jacobian, derivative

    def initial_guess(self, omega: float) -> np.ndarray:
        """Scaled unknowns of the stuck structure at Omega: the static step's motion and U_F."""
        return self.harmonic_rows(self.static, self.stuck_motion(omega)) / self.scale

    def failure(self, y: np.ndarray, frequency_ratio: float) -> str:
        """Why the point (y, Omega / omega_0) is not a converged periodic response, or '' where it is: its
        hysteresis repeats within MAX_PERIODS periods and its largest residual is at most RESIDUAL_TOLERANCE of
        its largest joint motion (unscaled)."""
        if not np.all(np.isfinite(y)):
            return "not a finite solution"
        if not self.deficit(self.scale * y.reshape(-1, self.n_t)).periodic:
            return f"hysteresis not periodic within {MAX_PERIODS} periods"
        error = float(np.abs(self(y, frequency_ratio)[0]).max() / max(np.abs(y).max(), np.finfo(float).tiny))
        return f"residual {error:.1e} of the joint motion" if error > RESIDUAL_TOLERANCE else ""

    def modal_harmonics(self, y: np.ndarray, frequency_ratio: float) -> np.ndarray:
        """(2H+1, n_modes) harmonics of the stuck modes' coordinates p_j (m kg^0.5) of the solution y."""
        omega = self.omega_0 * frequency_ratio
        g = self.deficit(self.scale * y.reshape(-1, self.n_t)).harmonics
        return modal_harmonics(self.system, g, omega, self.xi, self.load, self.excitation, resonant_target=True)


class ForcedResponse(NamedTuple):
    """The periodic response along the branch, its points (n,) in the order followed (Omega back and forth
    through folds).

    frequency: Omega (n,) rad/s. drive: (n, 2H+1) harmonics of the drive point's displacement (m), (X_0, X_a1,
    X_b1, ...), x(t) = X_0 + sum_k X_ak cos k Omega t + X_bk sin k Omega t. response: (n, 2H+1, n_r) the same at
    the response rows. amplitude, phase: (n,) the drive point's first harmonic, |X_a1 - i X_b1| (m) and its angle
    (rad; negative: lagging the force). joint_harmonics: (n, 2H+1, n_t) tangential motion of the slipping elements
    (m). modal_harmonics: (n, 2H+1, n_modes) the stuck modes' coordinates (m kg^0.5). converged: (n,) the full
    equations hold at the point's own scale with a periodic hysteresis (``ForcedEquations.failure``); reason: why
    not, '' where converged. at_frequencies: indices of the points at the asked frequencies, in their order (fewer
    where the branch stopped). reached: whether the branch reached the last asked frequency (else its corrector
    failed before). harmonics: H; samples: N of the AFT; stuck_frequency: omega_0 of the stuck target mode, rad/s.
    """

    frequency: np.ndarray
    drive: np.ndarray
    response: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    joint_harmonics: np.ndarray
    modal_harmonics: np.ndarray
    converged: np.ndarray
    reason: tuple
    at_frequencies: np.ndarray
    reached: bool
    harmonics: int
    samples: int
    stuck_frequency: float


def band_frequencies(system: JointSystem, frequencies: np.ndarray) -> np.ndarray:
    """The asked frequencies (rad/s) and the stuck structure's natural frequencies sqrt(mu_j) between them,
    sorted: the continuation's points to reach. A stuck resonance narrower than a step would otherwise be stepped
    over where the branch's tangents on its two flanks are alike."""
    natural = np.sqrt(np.abs(system.eigenvalues))
    return np.unique(np.concatenate([frequencies, natural[(natural > frequencies[0]) & (natural < frequencies[-1])]]))


def forced_response(system: JointSystem, drive, force: float, frequencies, harmonics: int, linear_damping,
                    response=None, samples: int = SAMPLES, load=None, step: float = 0.02) -> ForcedResponse:
    """The periodic response of ``system`` to F cos(Omega t) at the drive point, from the first of the increasing
    ``frequencies`` (rad/s) through every further one (module docstring).

    drive: (n_modes,) the drive point's row in the structure's coordinates (those of ``JointSystem.shapes``): its
    displacement is drive^T eta and the force drive F cos(Omega t). force: F, N. harmonics: H >= 1.
    linear_damping: zeta of every stuck mode, or (n_modes,). response: (n_r, n_modes) rows of further response
    points (default none). load: static load (n_modes,), N kg^-0.5, as ``nonlinear.epmc.ModeEquations``. step:
    the continuation's first step in the scaled unknowns and Omega / omega_0. Raises RuntimeError where Newton's
    method does not converge at the first frequency."""
    frequencies = np.asarray(frequencies, dtype=float)
    if frequencies.ndim != 1 or frequencies.size == 0 or np.any(frequencies <= 0) or np.any(np.diff(frequencies) <= 0):
        raise ValueError(f"frequencies must be positive and increasing; got {frequencies}")
    drive = np.asarray(drive, dtype=float)
    rows = np.vstack([drive, np.zeros((0, drive.size)) if response is None else np.atleast_2d(response)])
    band = band_frequencies(system, frequencies)
    equations = ForcedEquations(system, force * (drive @ system.shapes), viscous_damping(system, linear_damping),
                                harmonics, band, samples, load)
    start, converged, _ = newton(equations, equations.initial_guess(band[0]), band[0] / equations.omega_0)
    if not converged:
        raise RuntimeError(f"the forced response did not converge at the first frequency {band[0]:.6g} rad/s")
    branch = pseudo_arclength(equations, start, band[0] / equations.omega_0, band[1:] / equations.omega_0, step,
                              max_turn=MAX_TURN)
    asked = np.concatenate([[0], branch.at_stops[np.isin(band[1:1 + branch.at_stops.size], frequencies)]])
    modal = np.array([equations.modal_harmonics(y, ratio) for y, ratio in zip(branch.unknowns, branch.parameters)])
    physical = modal @ (rows @ system.shapes).T  # (n, 2H+1, 1 + n_r)
    first = physical[:, 1, 0] - 1j * physical[:, 2, 0]
    reasons = tuple(equations.failure(y, ratio) for y, ratio in zip(branch.unknowns, branch.parameters))
    return ForcedResponse(equations.omega_0 * branch.parameters, physical[:, :, 0], physical[:, :, 1:], np.abs(first),
                          np.angle(first), equations.scale * branch.unknowns.reshape(len(modal), -1, equations.n_t),
                          modal, np.array([not reason for reason in reasons]), reasons,
                          asked.astype(int), branch.reached, harmonics, samples,
                          equations.omega_0)


def stepped_sine(space: JointSpace, model: str, design, forces, frequencies, linear_damping: float,
                 harmonics: int = 3, sensor: int = 0, samples: int = SAMPLES) -> list[ForcedResponse]:
    """Forced responses of one design of ``model`` on a superelement's joint space at several force levels, driven
    and read at its sensors: the force at sensor row ``sensor`` (along its measuring axis, as the virtual hammer
    test hits it), the response at every sensor (``ForcedResponse.response``, (n, 2H+1, n_sensors)).

    forces: (n_levels,) N; frequencies: increasing Omega, rad/s; linear_damping: zeta_0 of every stuck mode (the
    structure's other mechanisms, paper Table 1). The joint system is ``nonlinear.epmc.joint_system``'s (the
    registry's sliders at their default resolution)."""
    system = joint_system(space, model, design)
    sensors = space.superelement.sensors @ space.modes  # (n_sensors, n_modes): rows in the joint space's coordinates
    return [forced_response(system, sensors[sensor], float(force), frequencies, harmonics, linear_damping, sensors,
                            samples) for force in forces]
