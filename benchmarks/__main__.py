"""``make bench``: every stage's benchmark table, one after the other."""

import importlib

STAGES = ("benchmarks.geometry", "benchmarks.fem", "benchmarks.qsma")

for module_name in STAGES:
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as error:
        if error.name != module_name:
            raise
        continue
    module.main()
    print()
