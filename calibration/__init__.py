"""The calibration stage (docs/design.md section 11): each friction model of a finished study fitted to each
structure's measured backbone, with zeta_0 fitted beside the joint. ``surrogacy fit`` runs it
(:mod:`calibration.commands`).

What is fitted (:mod:`calibration.objectives`)
    FitSpace, fit_space, physical      the unit box: Table 3 parameters and zeta_0
    model_curves, linf_errors, plain_errors, normalised_residuals
                                       QSMA at the measured levels against the measurement
    FrontArchive                       the non-dominated set of every design a calibration evaluates
The local phase (:mod:`calibration.local_fit`)
    local_fit, jacobian, uncertainty   weighted least squares (restarted where its budget stops it),
                                       central-difference Jacobian, covariance
The whole calibration (:mod:`calibration.calibrate`)
    calibrate, Calibration             NSGA-II to a front that stops moving, polishes along it, best compromise
    multistart, scanned                the deterministic multistart over the box, coordinate scans
Files (:mod:`calibration.files`, :mod:`calibration.workflow`)
    calibration_record, read_calibration, write_fronts, plot_fits, write_markdown, spread_table
    calibrate_study                    a study's folder in, the calibration's folder out, resumable
    nested_row                         a model's best compromise against the model it contains
    calibrate_replicates               studies of other seeds, for the spread of the best compromises
"""
