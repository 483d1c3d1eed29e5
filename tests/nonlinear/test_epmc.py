"""EPMC by harmonic balance: the stuck beam gives its linear mode, a single-DOF Jenkins oscillator its closed-form
describing-function backbone, the damping balances the loop's dissipation, and the harmonics converge."""

import numpy as np
import scipy.linalg

from nonlinear.condensation import joint_space, stuck_modes
from nonlinear.epmc import converged_harmonics, joint_system, nonlinear_mode, slider_resolution, slip_amplitude
from nonlinear.friction_models import friction_model
from nonlinear.iwan import segalman_constants
from nonlinear.harmonic_balance import JointSystem, periodic_hysteresis, stacked_sliders, virgin_state
from nonlinear.jenkins import describing_function
from nonlinear.joint import joint_row_stiffness, patch_elements, stuck_stiffness
from nonlinear.qsma import qsma_reference
from nonlinear.sliders import jenkins_sliders
from nonlinear.slip_laws import masing_dissipation
from reduction.superelement import beam_superelement

SPRING, JOINT, SLIP = 1.0e6, 2.0e6, 10.0  # N/m, N/m, N: unit mass on a spring with a Jenkins element beside it


def jenkins_oscillator() -> JointSystem:
    """m = 1 kg, k = 1e6 N/m in parallel with a Jenkins element (K_T = 2e6 N/m, F_S = 10 N): one mode, mu = k + K_T
    stuck (275.7 Hz), k in macroslip (159.2 Hz); the element's motion is the modal coordinate."""
    return JointSystem(np.array([SPRING + JOINT]), np.eye(1), np.ones((1, 1)), 0, np.array([JOINT]),
                       stacked_sliders([jenkins_sliders(JOINT, SLIP)]))


def test_single_dof_jenkins_follows_its_describing_function():
    """With one harmonic, EPMC is the describing-function backbone (``nonlinear.jenkins.describing_function``):
    omega^2 = k + K_eq(q), zeta = D(q) / (2 pi q^2 omega^2), from stuck (q = 0.9 F_S / K_T: exactly the linear
    mode) through slip onset to deep macroslip (100 F_S / K_T, where omega nears sqrt(k)). The time loop's 512
    samples per period leave an error of its quadrature of the slip onset's kink: measured 1.7e-6 in frequency and
    1.5e-5 in damping (3e-7 and 3e-6 at 1024 samples)."""
    amplitude = SLIP / JOINT * np.array([0.9, 1.2, 2.0, 5.0, 20.0, 100.0])
    mode = nonlinear_mode(jenkins_oscillator(), amplitude, harmonics=1, samples=512)
    assert mode.converged.all()
    equivalent, dissipative = describing_function(amplitude, JOINT, SLIP)
    omega_squared = SPRING + equivalent
    assert mode.frequency[0] == np.sqrt(SPRING + JOINT) and mode.damping[0] == 0.0
    np.testing.assert_allclose(mode.frequency, np.sqrt(omega_squared), rtol=3e-6)
    np.testing.assert_allclose(mode.damping[1:], dissipative[1:] / (2 * omega_squared[1:]), rtol=3e-5)
    assert mode.frequency[-1] < 0.6 * mode.frequency[0] and mode.damping.max() > 0.15


def test_damping_balances_the_dissipation_of_the_loop():
    """Energy per period with five harmonics: the negative damping's input xi int p'^2 dt = pi omega xi sum_k
    k^2 |P_k|^2 equals the dissipation int f dr of the Jenkins loop sampled independently at 4096 points from the
    mode's motion (within the 256-sample AFT's quadrature error: measured 4e-5 to 9e-5)."""
    amplitude = SLIP / JOINT * np.array([1.5, 4.0, 30.0])
    system = jenkins_oscillator()
    mode = nonlinear_mode(system, amplitude, harmonics=5, samples=256)
    k = np.arange(1, 6)
    samples = 4096
    tau = 2 * np.pi * np.arange(samples) / samples
    for level in range(amplitude.size):
        harmonics = mode.joint_harmonics[level, :, 0]
        cos, sin = harmonics[1::2], harmonics[2::2]
        motion = harmonics[0] + np.cos(np.outer(tau, k)) @ cos + np.sin(np.outer(tau, k)) @ sin
        loop = periodic_hysteresis(system, motion[None, :], virgin_state(system.sliders))
        force = JOINT * motion - loop.deficit[0]
        closed = np.append(motion, motion[0])
        dissipation = np.sum(0.5 * (force + np.roll(force, -1)) * np.diff(closed))
        xi = 2 * mode.damping[level] * mode.frequency[level]
        supplied = np.pi * mode.frequency[level] * xi * np.sum(k ** 2 * (cos ** 2 + sin ** 2))
        np.testing.assert_allclose(supplied, dissipation, rtol=2e-4)


def test_harmonics_converge():
    """Frequency and damping of the Jenkins oscillator in microslip-to-macroslip (2 and 8 F_S / K_T) approach
    their 15-harmonic values as harmonics are added (odd counts; the loop is half-wave symmetric): the largest
    difference falls below 3e-5 in frequency and 2e-4 in damping, and ``converged_harmonics`` states the first
    count that agrees with the next within its tolerances."""
    amplitude = SLIP / JOINT * np.array([2.0, 8.0])
    system = jenkins_oscillator()
    counts = (1, 3, 5, 9, 15)
    sequence = converged_harmonics(system, amplitude, counts=counts, samples=256, frequency_tolerance=0.0,
                                   damping_tolerance=0.0)  # never met: every count is computed
    assert not sequence.converged and sequence.harmonics == 15
    reference = sequence.modes[-1]
    frequency_error = [np.max(np.abs(mode.frequency / reference.frequency - 1)) for mode in sequence.modes[:-1]]
    damping_error = [np.max(np.abs(mode.damping / reference.damping - 1)) for mode in sequence.modes[:-1]]
    assert frequency_error[0] > 1e-3 and damping_error[0] > 1e-2  # one harmonic is visibly not enough
    assert frequency_error[-1] < 3e-5 and damping_error[-1] < 2e-4  # nine harmonics: 1.1e-5 and 5e-5
    assert frequency_error[-1] < frequency_error[0] / 10 and damping_error[-1] < damping_error[0] / 10
    check = converged_harmonics(system, amplitude[:1], counts=(1, 3, 5, 7), samples=256,
                                frequency_tolerance=1e-4, damping_tolerance=2e-3)
    assert check.converged and check.harmonics in (3, 5)
    assert check.frequency_change[-1] <= 1e-4 and check.damping_change[-1] <= 2e-3
    assert check.frequency_change[0] > 1e-4 or check.damping_change[0] > 2e-3  # one harmonic is not enough


def test_stuck_beam_gives_its_linear_mode(beam_roms):
    """The BRB with its joint stuck (F_S = 1e11 N: no slider slides at q = 1e-5 m kg^0.5): frequency and mode
    shape are those of the linear mode, from the compiled small exact eigenproblem (``stuck_modes``) to 1e-10,
    the damping and every harmonic but the fundamental exactly zero; and to the round-off of a dense solve of the
    assembled superelement with its joint springs (eps times its condition, about 1e-10 here)."""
    superelement = beam_superelement(beam_roms / "BRB.npz")
    space = joint_space(superelement)
    design = np.array([1e11, 1e6, 1e7] * 3)
    system = joint_system(space, "jenkins", design)
    mode = nonlinear_mode(system, [1e-5, 3e-5], harmonics=3)
    assert mode.converged.all()
    linear = stuck_modes(space, stuck_stiffness(patch_elements("jenkins", design, superelement.patch_groups)))
    np.testing.assert_allclose(mode.frequency, np.sqrt(linear.eigenvalue[0]), rtol=1e-10)
    np.testing.assert_array_equal(mode.damping, 0.0)
    shape = system.shapes @ mode.modal_harmonics[:, 1].T / mode.amplitude  # (n_modes, levels), unit norm
    np.testing.assert_allclose(shape.T, np.tile(linear.shape[0], (2, 1)), rtol=0, atol=1e-10)
    np.testing.assert_array_equal(np.delete(mode.modal_harmonics, 1, axis=1), 0.0)
    springs = joint_row_stiffness(np.tile([1e6, 1e6, 1e7], superelement.n_patches), len(superelement.joint_motion))
    stiffness = superelement.stiffness + superelement.joint_motion.T @ (springs[:, None] * superelement.joint_motion)
    eigenvalues, vectors = scipy.linalg.eigh(stiffness, superelement.mass)
    physical = space.modes @ shape[:, 0]
    target = np.argmax(np.abs(vectors.T @ superelement.mass @ physical))
    np.testing.assert_allclose(mode.frequency[0] ** 2, eigenvalues[target], rtol=1e-9)


def test_epmc_and_qsma_agree_in_microslip_on_the_beam(beam_roms):
    """The BRB with four-parameter Iwan joints (thousands of sliders per element) at slip ratios 2e-3 to 0.13:
    EPMC and QSMA are two routes to the same weakly nonlinear mode, so they agree where the mode shape barely
    changes: frequency within 2e-4 and damping within 1e-3 (measured 1e-5 to 7.5e-5 and 1e-4 to 3.5e-4, both
    growing with the slip). About 5 s."""
    space = joint_space(beam_superelement(beam_roms / "BRB.npz"))
    design = np.array([300.0, 1e7, -0.5, 0.1, 1e9] * 3)
    amplitude = np.geomspace(5e-6, 3e-4, 4)
    qsma = qsma_reference(space, "iwan4", design, amplitudes=amplitude)
    mode = nonlinear_mode(joint_system(space, "iwan4", design), amplitude, harmonics=3)
    assert mode.converged.all() and qsma.converged.all()
    assert 1e-3 < qsma.slip_ratio.max(axis=1)[0] and qsma.slip_ratio.max() < 0.5
    np.testing.assert_allclose(mode.frequency, qsma.frequency, rtol=2e-4)
    np.testing.assert_allclose(mode.damping, qsma.damping, rtol=1e-3)


def iwan_oscillator(smallest: float) -> JointSystem:
    """The Jenkins oscillator's spring (1 kg, k = 1e6 N/m) with a four-parameter Iwan element instead (F_S = 10 N,
    K_T = 2e6 N/m, chi = -0.5, beta = 1), its sliders resolving slip displacements from ``smallest`` phi_max."""
    sliders = friction_model("iwan4").sliders(SLIP, JOINT, -0.5, 1.0, 1.0, smallest=smallest)
    return JointSystem(np.array([SPRING + JOINT]), np.eye(1), np.ones((1, 1)), 0, np.array([JOINT]),
                       stacked_sliders([sliders]))


def test_iwan_sliders_resolve_the_lowest_amplitude():
    """An Iwan element cycling far below its macroslip displacement (1e-6 and 1e-3 phi_max): with one harmonic the
    motion is a cosine, so EPMC's damping is the element's Masing dissipation over 2 pi q^2 omega^2, the closed form
    (``nonlinear.slip_laws.masing_dissipation``). With the sliders ``slider_resolution`` asks for (smallest 1e-2
    of the lowest slip ratio) it holds to 1e-4 (measured 1e-5); with the default smallest slider, 1e-4 phi_max,
    the element at 1e-6 phi_max dissipates nothing (to round-off), and at 2e-4 phi_max several per cent too much."""
    phi_max, r, s = segalman_constants(SLIP, JOINT, -0.5, 1.0)
    ratios = np.array([1e-6, 2e-4, 1e-3])
    smallest = slider_resolution(ratios[:1], [1.0])[0]
    assert abs(smallest / 1e-8 - 1) < 1e-15
    resolved = nonlinear_mode(iwan_oscillator(smallest), ratios * phi_max, harmonics=1, samples=512)
    default = nonlinear_mode(iwan_oscillator(1e-4), ratios * phi_max, harmonics=1, samples=512)
    dissipation = 4 * phi_max * masing_dissipation(ratios, r, s, -0.5, 1.0)
    closed_form = dissipation / (2 * np.pi * (ratios * phi_max) ** 2 * resolved.frequency ** 2)
    np.testing.assert_allclose(resolved.damping, closed_form, rtol=1e-4)
    assert default.damping[0] < 1e-9 * closed_form[0] and abs(default.damping[1] / closed_form[1] - 1) > 0.03


def test_slider_resolution_only_for_elements_that_dissipate():
    """Elements dissipating less than 1e-6 of the total keep the default resolution; the others resolve 1e-2 of
    their slip ratio, within [1e-16, 1e-4] phi_max."""
    resolution = slider_resolution([1e-3, 1e-5, 1e-13, 1e-20, 1e-5], [1.0, 1.0, 1.0, 1.0, 1e-7])
    np.testing.assert_allclose(resolution, [1e-5, 1e-7, 1e-15, 1e-16, 1e-4], rtol=1e-15)


def test_epmc_and_qsma_agree_on_a_joint_dissipating_far_below_slip(beam_roms):
    """A Table 3 iwan4 design on the BRB whose dissipation comes from the end patches' elements at slip ratios of
    7e-6 to 7e-5 (F_S = 8e7 N), the middle of the joint reaching 0.01 to 0.1: EPMC with the sliders resolving the
    lowest amplitude (``joint_system(..., lowest_amplitude)``) agrees with QSMA to 1e-5 in damping and 1e-6 in
    frequency (measured 4e-6 and 1e-7); the default sliders (smallest 1e-4 phi_max) give the end patches no
    dissipation at the lowest level (zeta 5e-11 against 4.9e-7) and twice too much at the next."""
    space = joint_space(beam_superelement(beam_roms / "BRB.npz"))
    design = np.array([8.17201748e+07, 1.11270357e+09, -3.95759134e-01, 5.63183133e+00, 3.35321966e+11,
                       2.26788201e+04, 1.36883729e+13, -9.86343880e-01, 4.41765940e+01, 3.46928847e+04,
                       1.31146409e+06, 4.04835573e+10, -6.68848406e-01, 2.07260468e+02, 1.43699907e+06])
    amplitude = slip_amplitude(space, "iwan4", design) * np.array([0.01, 0.1])
    qsma = qsma_reference(space, "iwan4", design, amplitudes=amplitude)
    resolved = nonlinear_mode(joint_system(space, "iwan4", design, lowest_amplitude=amplitude[0]), amplitude, 1)
    default = nonlinear_mode(joint_system(space, "iwan4", design), amplitude, 1)
    assert qsma.converged.all() and resolved.converged.all()
    np.testing.assert_allclose(resolved.damping, qsma.damping, rtol=1e-5)
    np.testing.assert_allclose(resolved.frequency, qsma.frequency, rtol=1e-6)
    assert default.damping[0] < 1e-3 * qsma.damping[0] and default.damping[1] > 1.5 * qsma.damping[1]
