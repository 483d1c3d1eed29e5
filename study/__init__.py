"""The study stage (DESIGN section 7): virtual experiments, designs, errors, Pareto fronts, acceptance,
surrogacy, ANOVA, the discrepancy loop and the report. Nothing is implemented here yet.
"""
