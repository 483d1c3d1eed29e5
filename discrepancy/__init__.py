"""The model-discrepancy loop: given a measured backbone and a model that does not fit it, which missing effect
explains the residual; the effect added, the model refitted, the errors before and after; "unexplained" rather than
a guess. ``surrogacy discrepancy`` runs it (:mod:`discrepancy.commands`).

The effects (:mod:`discrepancy.effects`)
    EFFECTS, effect                          the registry: each effect's parameters, in the joint's law or outside it
The loop and the one-mode route (:mod:`discrepancy.loop`)
    model_backbone, fit                      the one-mode joint model, weighted least squares
    discrepancy_loop, select_effects         forward selection by BIC, stepwise swap and drop; Verdict
    with_findings                            the ring-down's signal findings beside the verdict
The superelement route (:mod:`discrepancy.superelement_route`)
    from_study, structure_discrepancy_loop   a study's structure and Pareto designs as the reference model
The nominal (:mod:`discrepancy.nominal`)
    low_amplitude_nominal, nominal_record    f_0 and zeta_0 given or estimated from the measurement's lowest decade
The loop on files (:mod:`discrepancy.workflow`)
    measured_input, study_input, run_loop    a backbone file or a study's structure -> the loop -> its files
Files (:mod:`discrepancy.files`)
    write_verdict                            discrepancy.md/.png/.json (the measurement is read by
                                             ``experiment.measured_files``, binned by ``study.structures``)
    read_final_model, write_model_curve      the final one-mode model read back, its curve with the band as CSV
Data with known content for tests (:mod:`discrepancy.virtual_data`, labelled virtual)
    undeclared_backbone, undeclared_ringdown and their writers
"""
