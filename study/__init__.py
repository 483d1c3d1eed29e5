"""The study stage (docs/design.md section 7; paper sections 4.4, 5.2): can a joint fitted on one structure (the
surrogate) be trusted in another (the real one)? ``surrogacy study`` runs it step by step (:mod:`study.commands`,
:mod:`study.workflow`).

Measurements to fit (:mod:`study.datasets`, :mod:`study.structures`; the beams' from :mod:`virtual_experiment`)
    DATASETS, dataset, Dataset  the registry: the beams (virtual experiments) and the ASB (measured), each with
                                its structures, friction models, damping cases and rule, measurements and
                                superelement format
    write_asb_measurements      the ASB's measured backbones in the backbone CSV format
    structure, Structure        superelement, target mode chosen from the measured frequency, levels to fit
Designs and errors (:mod:`study.designs`, :mod:`study.errors`, :mod:`study.exploration`)
    design_chunk                chunk c of a replicated Latin hypercube over paper Table 3, from the seed
    design_errors, accepted     L-infinity errors of paper Eqs. 26-27 per design and structure, acceptance
    explore, read_exploration   every chunk on every structure to Parquet; resumable; serial or dask
    check_explored              the analysis' check: the whole exploration of the current inputs, each chunk's
                                rows the designs its seed regenerates (chunk_defect)
Answers (:mod:`study.surrogacy`, :mod:`study.subset_simulation`, :mod:`study.pareto`, :mod:`study.anova`,
:mod:`study.prestress`)
    surrogacy_matrix            SC_IJ (Eq. 29) with binomial intervals; replicate spread; bounds sweep
    subset_simulation           SC_IJ and P(accepted by I) at tight bounds, sampled inside I's region
    surrogacy_confidence        a study's SC_IJ at given bounds (:mod:`study.confidence`): subset simulation of each
                                surrogate beside the sample counted there; estimate_inputs, the study, damping
                                case and bounds an estimate runs on; read_bounds, the bounds CSV reader
    non_dominated, nsga2_front  Pareto fronts of the sample and of NSGA-II seeded from it (Fig. 6)
    surrogacy_anova             Table 6's four-way ANOVA (statsmodels)
    compare                     the SBRB with and without prestress (Fig. 12)
Files (:mod:`study.parameters`, :mod:`study.workflow`, :mod:`study.analysis`, :mod:`study.figures`, :mod:`study.report`)
    defaults                    the configuration's sections ([study], [sample], [acceptance], [pareto])
    run_steps                   measurements, explore, analyse, report on files
    sample_counts               one pass over a model's chunks: every count and front the analysis needs
    analysis tables and figures, report.md
"""
