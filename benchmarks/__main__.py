"""``make bench``: every stage's benchmark table, one after the other."""

import importlib

STAGES = ("benchmarks.geometry", "benchmarks.fem", "benchmarks.qsma", "benchmarks.study")

for module_name in STAGES:
    importlib.import_module(module_name).main()
    print()
