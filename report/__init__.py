"""The pipeline's report: one Markdown file with every stage's figures and tables, read back from the files the
stages wrote (:mod:`report.document`); ``surrogacy report`` writes it (:mod:`report.commands`).

    Folders                 the build and results folders and the run log a report is made from
    write_pipeline_report   the report, section by section in the order the data flows
    study_section           a dataset's study from its records (:mod:`report.studies`)
    epmc_section            QSMA against EPMC on the studies' representative designs (:mod:`report.epmc`)
    read_record, read_as    the stages' records read back, a damaged one named (:mod:`report.records`)
    measured_stage_not_run  a stage that reads measured data and did not run, named (:mod:`report.markdown`)
"""
