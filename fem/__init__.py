"""The finite-element stage (scikit-fem, quadratic tetrahedra): preload with contact, stress stiffness, tied modes
(docs/design.md section 3).

- ``elasticity``: ``Material``, ``solid_mesh``, ``stiffness_matrix``, ``mass_matrix``, ``rigid_body_modes``.
- ``bolts``: ``Bolt``, ``BOLT_PRELOAD``, shank stiffness, stress stiffness and mass joined by washer couplings
  (``bolts_stiffness``, ``preload_forces``, ``bolts_mass``).
- ``coupling``: distributing (RBE3-like) couplings: ``nodal_areas``, ``rigid_average``, ``coupling_matrix``.
- ``contact``: ``frictionless_contact`` -> ``ContactSolution``, the preload solve.
- ``stress_stiffness``: ``stress_stiffness_matrix``, K_sigma from a prestress.
- ``solver``: ``factorize``, ``natural_modes``, ``frequencies_hz``.
- ``modes``: ``tied_modes``, ``interface_quadratic_pairs``, ``node_dofs``.
- ``springs``: ``patch_couplings``, ``joint_stiffness``, linear joint springs between patches.
- ``prestress``: ``prestressed_beam`` -> ``PrestressedBeam``, the whole stage for one beam in memory.
- ``render``: ``render_fe`` (contact pressure, first bending).
- ``convergence``, ``frequency_tuning``, ``calculix``: mesh convergence (``write_study``: its table and record), the
  joint springs and the LBRB/SBRB geometry tuned to the measured frequencies (``write_tuning``: its record), a
  CalculiX cross-check.
- ``fe_files``: ``make_fe`` (one beam's result files, cached), ``check_fe_inputs``, ``read_csr``, ``beam_inputs``,
  ``FeInputError``.
- ``commands``: ``surrogacy fe``, ``fe-convergence``, ``tune-frequencies``.
"""
