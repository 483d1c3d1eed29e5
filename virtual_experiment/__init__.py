"""Virtual experiments: measurements simulated with the joint model, for the beams whose measured backbones are
not public. Every file they write is labelled virtual.

Reference joint (:mod:`virtual_experiment.reference_joint`)
    read_low_amplitude_measurements, read_parameter_limits   the paper's Tables 1 and 3
    uniform_interface, reference_joint   one uniform interface tuned to the BRB's measured frequency
Hammer test (:mod:`virtual_experiment.hammer_test`)
    HammerTest, hammer_hits, hit_pool    hits simulated by transient time stepping, one worker process per core
    virtual_experiment(s)                hits processed exactly like a measurement into a backbone, and written
"""
