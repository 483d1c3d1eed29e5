"""Joint model and its nonlinear modal analysis: friction elements, QSMA, transient ring-down.

docs/design.md section 5. Ring-downs (measured, or simulated here) are processed into backbones by ``experiment``.

Friction elements (:mod:`nonlinear.jenkins`, :mod:`nonlinear.iwan`, :mod:`nonlinear.sliders`)
    jenkins.backbone, .tangent, .dissipation          Jenkins element in closed form
    iwan.four_parameter_*, iwan.five_parameter_*      Segalman's 4-parameter and the 5-parameter Iwan element
    jenkins_sliders, iwan_sliders, slider_response    the same elements as parallel sliders, for time stepping
Friction models (:mod:`nonlinear.friction_models`, the registry every other module asks)
    FRICTION_MODELS, friction_model   jenkins, iwan4, iwan5, iwan4_stuck, iwan4_core: parameters, limits, slip law
Joint (:mod:`nonlinear.joint`, :mod:`nonlinear.parameters`)
    patch_elements, random_designs, stuck_stiffness   a design's elements on the patches (Table 3 parameters)
    joint_row_stiffness         the springs on every joint row (normal K_z on the patch rotations' rows too)
Joint space and stuck modes (:mod:`nonlinear.condensation`, :mod:`nonlinear.stuck_modes`)
    joint_space                 unjoined modes of a superelement and the joint's relative motion in them
    stuck_modes, stuck_designs  linear modes with the joint stuck: one design, many designs (compiled)
Small dense linear algebra (:mod:`nonlinear.dense_linear_algebra`, compiled)
    cholesky, ldl_eliminate, ldl_back_substitute, solve_dense, symmetric_eigen: factorisations, solves, Jacobi
    drop_stale_kernels (:mod:`nonlinear.compiled_cache`)  the kernels' disk cache keyed on all their sources
QSMA (:mod:`nonlinear.qsma`, :mod:`nonlinear.qsma_vectorised`)
    qsma_reference              single-design oracle: frequency and damping against modal amplitude or force
    qsma_designs                the same over many designs at once
    qsma_designs(device="cuda")  its stuck modes and levels on a CUDA GPU (:mod:`nonlinear.qsma_cuda`: the kernels'
                                 source, numba-cuda; :mod:`nonlinear.compute_devices` names the devices)
Harmonic balance, EPMC and forced response (:mod:`nonlinear.harmonic_balance`, :mod:`nonlinear.hysteresis_kernel`,
:mod:`nonlinear.epmc`, :mod:`nonlinear.forced_response`)
    JointSystem, slip_deficit_harmonics, pseudo_arclength   the joint space's harmonic balance with AFT of the sliders
    joint_system, nonlinear_mode, converged_harmonics        EPMC: the amplitude-dependent nonlinear mode
    compare_with_qsma                                        EPMC beside QSMA at the same amplitudes
    forced_response, stepped_sine                            the periodic response to a harmonic force at a drive point
Transient (:mod:`nonlinear.transient`)
    ring_down                   Newmark free decay; its sensors are an ``experiment.ringdown.RingDown``
    Hammer, hammer_impulse, sensor_modes
"""

from nonlinear.compiled_cache import drop_stale_kernels

drop_stale_kernels()
