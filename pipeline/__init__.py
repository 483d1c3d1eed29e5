"""The plumbing every stage shares.

- ``files``: ``atomic_path``, ``write_json``, ``sha256_file``, ``sha256_json``.
- ``cache``: the sidecar layout; ``is_current`` (the cache check), ``sidecar_record``, ``upstream_file``,
  ``package_versions``, ``StageInputError``.
- ``config``: ``resolve`` and ``configuration`` (defaults, ``--config`` TOML, ``--set``), ``add_config_arguments``,
  ``ConfigError``.
- ``render``: ``tetrahedral_grid``, ``triangle_surface`` (off-screen PyVista).
- ``published``: the paper's numbers the stages need, cited (Tables 1, 3, 5, 6, the BRB deck's dimensions), and
  ``paper_tables`` (a user's own tables in their place).
- ``public_data``: the public measured files (``REGISTRY``: pinned URL, name, SHA-256, size) and ``fetch``.
- ``runners``: one way to run independent tasks, passed in by the caller: ``SERIAL``, ``process_pool``, ``Dask``
  (a client's cluster), ``runner(scheduler)`` (what ``--scheduler`` names), ``local_cluster``.
- ``commands``: ``surrogacy data fetch``.
"""
