"""The reduction stage: whole-joint patches and the Hurty/Craig-Bampton superelement of each beam
(docs/design.md section 4).

- ``craig_bampton``: ``hurty_craig_bampton`` -> ``HurtyCraigBampton``, ``reduced_matrix``,
  ``rigid_body_properties``, ``virtual_dof_labels``.
- ``whole_joint``: ``reduce_beam`` -> ``BeamReduction``, ``whole_joint_superelement``, ``bolt_string_stiffness``,
  ``preload_vector``.
- ``sensors``: ``accelerometer_points``, ``point_recovery``.
- ``superelement``: ``Superelement``, ``save_superelement``, ``load_superelement``, ``read_asb_superelement``,
  ``ASB_CONFIGURATIONS``, ``tied_modal_eigenpairs`` (rad^2/s^2, in modal coordinates; ``fem.modes.tied_modes`` is
  the FE model's, in Hz), ``stuck_joint_modes``, ``rigid_reduced_coordinates``, ``beam_superelement`` (a beam's
  superelement as the study uses it, prestressed by default), ``balanced_stiffness``, ``normal_rotation_rows`` (the joint's rows on
  the patch rotations, ``Superelement.joint_motion``), ``target_mode`` (the mode a measurement saw),
  ``StructureError``.
- ``render``: ``render_mode``.
- ``rom_files``: ``make_rom`` (one beam's result files, cached), ``ReductionParameters``, ``fe_inputs``.
- ``commands``: ``surrogacy rom``.
"""
