"""Virtual experiments: measurements simulated with the joint model, for the beams whose measured backbones are
not public. Every file they write is labelled virtual.

Reference joint (:mod:`virtual_experiment.reference_joint`)
    uniform_interface, reference_joint   one uniform interface tuned to the BRB's measured frequency (Table 1)
    outside_limits                       a design's entries outside Table 3's limits
Hammer test (:mod:`virtual_experiment.hammer_test`)
    HammerTest, hammer_hits              hits simulated by transient time stepping, on the runner given
                                         (``pipeline.runners``: one worker process per core for the beams)
    virtual_experiment(s)                hits processed exactly like a measurement into a backbone, and written
Nonlinear mode of one design (:mod:`virtual_experiment.nonlinear_mode`)
    follow_mode                          its mode by harmonic balance (``nonlinear.epmc``) beside its QSMA backbone
    write_backbones                      both as virtual backbone CSVs at the same modal amplitudes
Command (:mod:`virtual_experiment.commands`)
    surrogacy epmc                       parses the options, follows the mode, writes and prints it
"""
