"""Forced response by harmonic balance: a stuck joint gives the closed-form receptance, a narrow resonance is
followed, a single-DOF Jenkins oscillator gives its describing-function response, the harmonics converge, the
Jacobian is the finite differences', the force's work balances the viscous and friction dissipation, and a beam
design softens and damps with the force."""

import numpy as np
import scipy.linalg
import scipy.optimize

from nonlinear.condensation import joint_space
from nonlinear.epmc import joint_system
from nonlinear.forced_response import ForcedEquations, forced_response, stepped_sine, viscous_damping
from nonlinear.harmonic_balance import JointSystem, periodic_hysteresis, stacked_sliders, virgin_state
from nonlinear.jenkins import describing_function
from nonlinear.joint import random_designs
from nonlinear.sliders import jenkins_sliders
from pipeline.published import TABLE1
from reduction.superelement import beam_superelement

from test_epmc import JOINT, SLIP, SPRING, jenkins_oscillator
from test_harmonic_balance import finite_difference_columns, three_element_system

DAMPING = 0.01  # zeta of the Jenkins oscillator's mode
STUCK = np.sqrt(SPRING + JOINT)  # rad/s: the Jenkins oscillator's stuck natural frequency


def chain() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three masses (1, 2, 1.5 kg) on springs in a chain from the ground (1e6, 2e6, 1.5e6 N/m) and a joint between
    masses 1 and 3 (relative motion B = [1, 0, -1]): mass, stiffness (3, 3) and B (1, 3)."""
    springs = np.array([1e6, 2e6, 1.5e6])
    stiffness = np.diag(springs + np.append(springs[1:], 0.0)) - np.diag(springs[1:], 1) - np.diag(springs[1:], -1)
    return np.diag([1.0, 2.0, 1.5]), stiffness, np.array([[1.0, 0.0, -1.0]])


def test_stuck_joint_gives_the_closed_form_receptance():
    """The chain with a Jenkins joint that never slips (F_S = 1e6 N, K_T = 3e6 N/m, 1 N of force) and damping
    ratios 0.02, 0.01, 0.03 on its three modes: the harmonic-balance response at the drive point (mass 2) and at
    masses 1 and 3 equals F H(Omega), H(Omega) = sum_r phi_r phi_r^T / (omega_r^2 - Omega^2 + 2 i zeta_r omega_r
    Omega) from the eigenvectors of the assembled stuck structure, to 1e-10 at every point of a band from half the
    first resonance to past the second (100 points, the amplitude varying by 1,600; measured 4e-14); the higher
    harmonics are zero."""
    mass, stiffness, joint = chain()
    stiffness_t, zeta = 3e6, np.array([0.02, 0.01, 0.03])
    eigenvalues, modes = scipy.linalg.eigh(stiffness, mass)  # the unjoined chain, eta with identity mass
    joint_modes = joint @ modes
    mu, shapes = np.linalg.eigh(np.diag(eigenvalues) + stiffness_t * joint_modes.T @ joint_modes)
    system = JointSystem(mu, shapes, (joint_modes @ shapes).T, 0, np.array([stiffness_t]),
                         stacked_sliders([jenkins_sliders(stiffness_t, 1e6)]))
    omega = np.sqrt(mu)
    frequencies = np.sort(np.concatenate([np.linspace(0.5 * omega[0], 1.2 * omega[1], 12), omega[:2]]))
    result = forced_response(system, modes[1], 1.0, frequencies, 3, zeta, response=modes[[0, 2]])
    assert result.reached and result.converged.all() and len(result.at_frequencies) == frequencies.size
    natural, phi = scipy.linalg.eigh(stiffness + stiffness_t * joint.T @ joint, mass)
    omega_squared, damping = natural[None, :], 2 * zeta * np.sqrt(natural)
    receptance = np.einsum("ir,jr,nr->nij", phi, phi, 1.0 / (omega_squared - result.frequency[:, None] ** 2
                                                              + 1j * damping * result.frequency[:, None]))
    computed = np.concatenate([result.drive[:, None, :], np.moveaxis(result.response, 2, 1)], axis=1)
    first = computed[:, :, 1] - 1j * computed[:, :, 2]
    expected = receptance[:, [1, 0, 2], 1]
    np.testing.assert_allclose(np.abs(first - expected) / np.abs(expected), 0.0, atol=1e-10)
    np.testing.assert_allclose(result.amplitude * np.exp(1j * result.phase), expected[:, 0], rtol=1e-10)
    assert np.all(computed[:, :, [0, 3, 4, 5, 6]] == 0.0)


def test_narrow_resonance_between_asked_frequencies_is_on_the_branch():
    """The Jenkins oscillator stuck (0.1 mN) with zeta = 1e-4 asked at 0.5 and 1.1 times its natural frequency
    only: the branch passes its resonance, a peak 1/(2 zeta) times the static response and 2e-4 wide, which a step
    from a flank would pass with the same tangent on the other; the points at the asked frequencies are the two
    asked."""
    result = forced_response(jenkins_oscillator(), np.ones(1), 1e-4, STUCK * np.array([0.5, 1.1]), 1, 1e-4,
                             samples=64)
    assert result.reached and result.converged.all()
    np.testing.assert_allclose(result.amplitude.max(), 1e-4 / (2e-4 * STUCK ** 2), rtol=1e-8)  # peak: 1 + 5e-9
    np.testing.assert_allclose(result.frequency[result.at_frequencies], STUCK * np.array([0.5, 1.1]), rtol=1e-15)


def describing_function_amplitude(omega: float, force: float) -> float:
    """The amplitude a (m) of the one-harmonic response of the Jenkins oscillator to F cos(Omega t):
    |k + K_eq(a) - Omega^2 + i (c Omega + K_D(a))| a = F (unit mass, c = 2 zeta omega_stuck), by bracketing between
    0 and F / (c Omega), where the left side is at least F."""
    damping = 2 * DAMPING * STUCK

    def balance(amplitude):
        equivalent, dissipative = describing_function(amplitude, JOINT, SLIP)
        return abs(SPRING + equivalent - omega ** 2 + 1j * (damping * omega + dissipative)) * amplitude - force

    return scipy.optimize.brentq(balance, 1e-3 * SLIP / JOINT, force / (damping * omega), xtol=1e-20, rtol=1e-14)


def test_single_dof_jenkins_follows_its_describing_function():
    """The Jenkins oscillator (1 kg, k = 1e6 N/m, K_T = 2e6 N/m, F_S = 10 N, zeta = 0.01) with one harmonic from
    0.5 to 1.3 times its stuck frequency: at 3 N (peak 1.26 slip displacements) and 10 N (3.6) the response
    amplitude is the describing function's (its root unique at every frequency) at every point of the branch to
    the AFT's quadrature of the slip onset, which falls about as 1/N^2: measured 4.3e-5 and 1.6e-4 with 512 samples
    per period, 4.1e-5 at 10 N with 1024 (8.5e-6 at 3 N; 2.4e-6 and 8.1e-6 with 2048). At 0.01 N it never slips
    and is the linear receptance 1 / (mu - Omega^2 + 2 i zeta sqrt(mu) Omega) to 1e-12 (measured 8e-15)."""
    system = jenkins_oscillator()
    frequencies = STUCK * np.linspace(0.5, 1.3, 5)
    for force, samples, tolerance in ((3.0, 512, 1e-4), (10.0, 512, 3e-4), (10.0, 1024, 8e-5)):
        result = forced_response(system, np.ones(1), force, frequencies, 1, DAMPING, samples=samples)
        assert result.reached and result.converged.all()
        assert result.amplitude.max() > 1.2 * SLIP / JOINT
        expected = [describing_function_amplitude(omega, force) for omega in result.frequency]
        np.testing.assert_allclose(result.amplitude, expected, rtol=tolerance)
    low = forced_response(system, np.ones(1), 0.01, frequencies, 1, DAMPING, samples=512)
    assert low.reached and low.converged.all() and low.amplitude.max() < SLIP / JOINT
    linear = 0.01 / (STUCK ** 2 - low.frequency ** 2 + 2j * DAMPING * STUCK * low.frequency)
    np.testing.assert_allclose(low.amplitude * np.exp(1j * low.phase), linear, rtol=1e-12)


def test_harmonics_converge_in_macroslip():
    """The Jenkins oscillator at 10 N (3.5 slip displacements at the peak) at 21 frequencies across its
    resonance with 1, 3, 5, 7, 9 and 11 harmonics (odd: the loop is half-wave symmetric), 256 samples: the largest
    change of the first harmonic's amplitude over the frequencies, and that of its peak, fall with every added pair
    of harmonics (measured 1.2e-1, 3.1e-3, 6.4e-4, 4.4e-4, 1.7e-4 and 3.5e-2, 2.3e-3, 4.1e-4, 3.6e-4, 9.1e-5)."""
    system = jenkins_oscillator()
    frequencies = STUCK * np.linspace(0.5, 0.9, 21)
    amplitudes = []
    for harmonics in (1, 3, 5, 7, 9, 11):
        result = forced_response(system, np.ones(1), 10.0, frequencies, harmonics, DAMPING, samples=256)
        assert result.reached and result.converged.all()
        amplitudes.append(result.amplitude[result.at_frequencies])
    amplitudes = np.array(amplitudes)
    change = np.max(np.abs(np.diff(amplitudes, axis=0)) / amplitudes[1:], axis=1)
    peak_change = np.abs(np.diff(amplitudes.max(axis=1))) / amplitudes.max(axis=1)[1:]
    assert np.all(np.diff(change) < 0) and np.all(np.diff(peak_change) < 0)
    assert change[0] > 1e-1 and change[-1] < 2e-4 and peak_change[-1] < 1e-4


def test_forced_jacobian_matches_finite_differences():
    """The forced residual's Jacobian in the joint harmonics and its derivative in Omega / omega_0 on three modes
    with a Jenkins, an Iwan and a stiction Iwan element, at a point off the solution near the first resonance:
    within 1e-6 of the largest entry (forward differences in the harmonics, the residual being piecewise linear
    in them; central in the frequency; measured 3.7e-7 and 1e-9)."""
    system = three_element_system()
    equations = ForcedEquations(system, 1.0 * system.shapes[0], viscous_damping(system, 0.02), 3,
                                [0.8 * 2 * np.pi * 100, 1.2 * 2 * np.pi * 100], samples=128)
    ratio = 0.97
    rng = np.random.default_rng(4)
    y = equations.initial_guess(ratio * equations.omega_0) + rng.normal(size=equations.size) * 0.05
    residual, jacobian, derivative = equations(y, ratio)
    assert np.abs(jacobian - np.eye(equations.size)).max() > 0.1  # the elements slip
    numeric = finite_difference_columns(lambda x: equations(x, ratio)[0], y)
    np.testing.assert_allclose(jacobian, numeric, rtol=0, atol=1e-6 * np.abs(jacobian).max())
    step = 1e-6
    numeric_derivative = (equations(y, ratio + step)[0] - equations(y, ratio - step)[0]) / (2 * step)
    np.testing.assert_allclose(derivative, numeric_derivative, rtol=0, atol=1e-6 * np.abs(derivative).max())


def test_force_work_balances_the_dissipation():
    """Energy per period at every point of a branch from 0.9 to 1.1 times the first stuck resonance of the
    three-element system (1 N, 3 harmonics, 128 samples): the force's work pi F X_b1 at the drive point equals the
    viscous dissipation pi Omega sum_j 2 zeta omega_j sum_k k^2 |P_jk|^2 plus the elements' int f dr, f from the
    time loop on the joint motion at the AFT's samples (exact there for band-limited motions), to 1e-8 (measured
    3e-14; the elements dissipate 4 to 68 % of the work along the branch)."""
    system = three_element_system()
    force, zeta, harmonics, samples = 1.0, 0.02, 3, 128
    result = forced_response(system, system.shapes[0], force, 2 * np.pi * 100 * np.linspace(0.9, 1.1, 3),
                             harmonics, zeta, samples=samples)
    assert result.reached and result.converged.all()
    k = np.arange(1, harmonics + 1)
    tau = 2 * np.pi * np.arange(samples) / samples
    for omega, drive, joint, modal in zip(result.frequency, result.drive, result.joint_harmonics,
                                          result.modal_harmonics):
        supplied = np.pi * force * drive[2]
        viscous = np.pi * omega * np.sum(2 * zeta * np.sqrt(system.eigenvalues)
                                         * np.sum(k[:, None] ** 2 * (modal[1::2] ** 2 + modal[2::2] ** 2), axis=0))
        motion = joint[0] + np.cos(np.outer(tau, k)) @ joint[1::2] + np.sin(np.outer(tau, k)) @ joint[2::2]
        velocity_per_tau = (-np.sin(np.outer(tau, k)) @ (k[:, None] * joint[1::2])
                            + np.cos(np.outer(tau, k)) @ (k[:, None] * joint[2::2]))
        loop = periodic_hysteresis(system, motion.T, virgin_state(system.sliders))
        friction = -2 * np.pi / samples * np.sum(loop.deficit.T * velocity_per_tau)
        assert friction > 0.0
        np.testing.assert_allclose(viscous + friction, supplied, rtol=1e-8)


def test_beam_stepped_sine_softens_and_damps_with_force(beam_roms):
    """A Table 3 Jenkins design on the BRB (seed 4: stuck at 171.4 Hz, its first element slipping at a modal
    amplitude of 1.26e-5 m kg^0.5, about 0.06 N at the drive sensor at resonance) with the BRB's Table 1 damping on
    every stuck mode, driven at sensor 0 from 0.9 to 1.05 times its stuck frequency with three harmonics: at
    0.02 N the joint stays stuck and every sensor's response is the stuck structure's receptance sum_j s_j s_0j /
    (mu_j - Omega^2 + 2 i zeta sqrt(mu_j) Omega) times the force to 1e-10 (measured 2e-15); at 0.2 and 2 N the
    peak moves down (0.9987 and 0.9567 of the stuck frequency) and the peak receptance falls from 1.7e-4 to 5.5e-5
    and 1.6e-5 m/N. About 4 s."""
    space = joint_space(beam_superelement(beam_roms / "BRB.npz"))
    design = random_designs("jenkins", 1, 3, np.random.default_rng(4))[0]
    system = joint_system(space, "jenkins", design)
    stuck, zeta, forces = np.sqrt(system.eigenvalues[system.target]), TABLE1["BRB"].damping, [0.02, 0.2, 2.0]
    results = stepped_sine(space, "jenkins", design, forces, stuck * np.linspace(0.9, 1.05, 7), zeta)
    assert all(result.reached and result.converged.all() for result in results)
    sensors = space.superelement.sensors @ space.modes @ system.shapes  # (n_sensors, n_modes)
    low = results[0]
    receptance = (sensors * sensors[0]) @ (1.0 / (system.eigenvalues[:, None] - low.frequency[None, :] ** 2 + 2j * zeta
                                                  * np.sqrt(system.eigenvalues)[:, None] * low.frequency[None, :]))
    measured = low.response[:, 1] - 1j * low.response[:, 2]  # (n, n_sensors)
    np.testing.assert_allclose(measured, forces[0] * receptance.T, rtol=0,
                               atol=1e-10 * forces[0] * np.abs(receptance).max())
    peak_receptance = [result.amplitude.max() / force for result, force in zip(results, forces)]
    peak_frequency = [result.frequency[np.argmax(result.amplitude)] / stuck for result in results]
    assert np.all(np.diff(peak_receptance) < 0) and peak_receptance[2] < 0.1 * peak_receptance[0]
    assert peak_frequency[0] == 1.0 and peak_frequency[1] < 0.999 and peak_frequency[2] < 0.96
