"""The command line, on top of every stage: nothing imports it.

- ``console``: the ``surrogacy`` console script, ``main``; it collects every stage package's ``commands`` module,
  handles Ctrl-C and SIGTERM as clean exits and appends each run to the run log (``log_run``).
- ``demo``: the demo's plan (``plan``: every stage's arguments, or why it is skipped) and runner (``run_steps``).
- ``commands``: ``surrogacy demo``.
"""
