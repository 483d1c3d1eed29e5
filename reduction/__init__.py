"""The reduction stage: whole-joint patches and the Hurty/Craig-Bampton superelement of each beam
(docs/design.md section 4).

- ``craig_bampton``: ``hurty_craig_bampton`` -> ``HurtyCraigBampton``, ``reduced_matrix``,
  ``rigid_reduced_coordinates``, ``rigid_body_properties``, ``virtual_dof_labels``.
- ``whole_joint``: ``reduce_beam`` -> ``BeamReduction``, ``whole_joint_superelement``, ``bolt_string_stiffness``,
  ``preload_vector``.
- ``sensors``: ``accelerometer_points``, ``point_recovery``.
- ``superelement``: ``Superelement``, ``save_superelement``, ``load_superelement``, ``read_asb_superelement``,
  ``tied_modes``, ``stuck_joint_modes``.
- ``render``: ``render_mode``.
- ``commands``: ``make_rom``, ``ReductionParameters``; ``surrogacy rom``.
"""
