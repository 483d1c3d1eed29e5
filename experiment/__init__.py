"""Measured (or simulated) ring-downs to backbones: natural frequency and damping against amplitude.

Paper section 3.1; docs/design.md section 6. Nothing here knows the joint model (``nonlinear``).

Ring-downs (:mod:`experiment.ringdown`, :mod:`experiment.ringdown_files`)
    RingDown                 one hit: time (n_samples,) s, signals (n_channels, n_samples) in SI units
    read_ringdown(path)      CSV, MATLAB .mat or UFF 58 file -> list of RingDown (one per hit)
    write_ringdown_csv, write_ringdown_mat, write_ringdown_uff58
                             list of RingDown -> file that read_ringdown reads back
Single-mode signals (:mod:`experiment.modal_filter`)
    modal_coordinates        q = Phi^+ y with the mode shapes at the sensors
    band_pass                zero-phase Butterworth band-pass
Estimators on one filtered decay (:mod:`experiment.hilbert`, :mod:`experiment.decay_cycles`)
    freevib                  Hilbert transform (paper Eqs. 1-4, Feldman's corrections optional)
    decay_cycles             zero-crossing period and logarithmic decrement, cycle by cycle
Backbones (:mod:`experiment.backbone`, :mod:`experiment.backbone_files`)
    ringdown_backbone        hits (and channels, mode shapes when known) -> RingDownBackbones: both estimators
                             averaged with spread
    twin_standard_errors     standard errors of the bin means: FreeVib on twin decays (:mod:`experiment.twin_decays`)
    average_backbones        records -> mean, spread and standard error on an amplitude grid
    mode_backbone            ringdown_backbone's result -> ModeBackbone (structure, provenance) for a study
    write_backbone, read_backbone
                             the documented backbone CSV
    write_freevib            freevib's files: the backbone CSV, both estimators' table and plot, the JSON sidecar
    read_asb_backbone        measured ASB backbone (.mat) -> ModeBackbone
What a backbone hides (:mod:`experiment.signal_checks`)
    ringdown_findings        a second mode, a drift over the hits, clipping, no pre-trigger, a truncated record
Ring-downs to a study's backbone in one call (:mod:`experiment.ringdown_analysis`)
    analyse_ringdown         ringdown_backbone, ringdown_findings and mode_backbone: what freevib, the examples and
                             the virtual experiments run
    analyse_ringdown_file    the same on one file's hits, the file's SHA-256 recorded with the backbone
Settings (:mod:`experiment.backbone`)
    checked_settings, check_nyquist   the band, grid and time scales refused before any signal is read
Command (:mod:`experiment.commands`)
    surrogacy freevib FILE --mode-hz F
"""
