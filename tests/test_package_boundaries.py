"""Package boundaries, read from the import statements (ast), so that they cannot erode unnoticed.

experiment/ (measured and simulated ring-downs, backbones) knows nothing of the joint model in nonlinear/;
nonlinear/ reads no measured-data files (it may build the ring-down type, experiment.ringdown); both import.
"""

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FILE_READERS = ("csv", "pyuff", "scipy.io", "experiment.ringdown_files", "experiment.backbone_files",
                "experiment.commands")
"""Modules that read or write files of measured data."""


def imported_modules(package: str) -> dict[str, set[str]]:
    """Module file name -> absolute names of the modules it imports (``from a.b import c`` counts a.b and
    a.b.c), for every module of a package."""
    imports = {}
    for path in sorted((ROOT / package).glob("*.py")):
        names = set()
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                names.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module)
                names.update(f"{node.module}.{alias.name}" for alias in node.names)
        imports[path.name] = names
    return imports


def within(name: str, prefix: str) -> bool:
    """Whether module ``name`` is ``prefix`` or inside it."""
    return name == prefix or name.startswith(prefix + ".")


def test_experiment_does_not_import_the_joint_model():
    offending = {module: sorted(name for name in names if within(name, "nonlinear"))
                 for module, names in imported_modules("experiment").items()}
    assert not any(offending.values()), offending


def test_nonlinear_reads_no_measured_data_files():
    offending = {module: sorted(name for name in names if any(within(name, reader) for reader in FILE_READERS))
                 for module, names in imported_modules("nonlinear").items()}
    assert not any(offending.values()), offending


@pytest.mark.parametrize("package", ["experiment", "nonlinear"])
def test_every_module_imports(package):
    for path in sorted((ROOT / package).glob("*.py")):
        importlib.import_module(f"{package}.{path.stem}" if path.stem != "__init__" else package)
