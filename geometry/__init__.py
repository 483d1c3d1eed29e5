"""The geometry stage: parametric gmsh models of the Brake-Reuss beams BRB, LBRB and SBRB (docs/design.md section 2).

- ``parameters``: ``BeamParameters``, ``MeshParameters`` (validated; ``GeometryError``), ``BEAMS``.
- ``brake_reuss``: the OpenCASCADE model and its mesh: ``build_beam_mesh``, ``cad_measures``, ``write_msh``.
- ``beam_mesh``: what later stages read: ``read_beam_mesh`` -> ``BeamMesh``, ``interface_partners``.
- ``properties``: analytic and meshed volumes, masses and patch areas (``half_volume``, ``beam_mass``,
  ``patch_areas``, ``tetrahedron_volumes``, ``triangle_areas``).
- ``beams``: ``make_beam``, one beam's ``.msh``, ``.vtu``, ``.png`` and sidecar, cached.
- ``render``: ``render_patches``.
- ``commands``: ``surrogacy beams``.
"""
