"""Package boundaries, read from the source (ast), so that they cannot erode unnoticed.

experiment/ (measured and simulated ring-downs, backbones) knows nothing of the joint model in nonlinear/;
nonlinear/ reads no measured-data files (it may build the ring-down type, experiment.ringdown); a package imports
only the packages before it in the data's flow, and no module of a package imports itself back through others; the
command line (cli/) comes after every stage and no module imports it; no library module imports a command module; no
module but the friction-model registry decides on a model's name, nor on a dataset's but the dataset registry; no
module but the effect registry names an effect of the discrepancy loop; no module but the runners starts workers.
Each check is also run on a planted package that breaks its rule (``PLANTED``), so that a check that finds nothing
cannot pass unnoticed.
"""

import ast
import graphlib
import importlib
from pathlib import Path

import pytest

from locations import REPOSITORY
from discrepancy.effects import EFFECT_NAMES
from nonlinear.friction_models import MODEL_NAMES
from study.datasets import DATASET_NAMES

ROOT = REPOSITORY
FILE_READERS = ("csv", "pyuff", "scipy.io", "experiment.ringdown_files", "experiment.backbone_files",
                "experiment.measured_files")
"""Modules that read or write files of measured data."""
PACKAGES = ("pipeline", "geometry", "fem", "reduction", "experiment", "nonlinear", "virtual_experiment", "study",
            "calibration", "discrepancy", "report", "cli")
"""The project's packages, in the order the data flows (a package imports only packages before it), the command line
(cli/, the console script and the demo, which drive every stage) last."""
LIBRARY = PACKAGES[:-1]
"""The packages that hold the library, each with its stage's command line in its ``commands`` module."""


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


FORMAT_READERS = ("experiment.backbone_files.read_backbone", "experiment.backbone_files.read_asb_backbone",
                  "experiment.ringdown_files.read_csv", "experiment.ringdown_files.read_mat",
                  "experiment.ringdown_files.read_uff58")
"""The readers of single formats: outside experiment/, a measured file is read through the registry
(``experiment.measured_files``), which chooses the format."""


def test_measured_files_are_read_through_the_registry_alone():
    offending = {f"{package}/{module}": sorted(names & set(FORMAT_READERS))
                 for package in PACKAGES if package != "experiment"
                 for module, names in imported_modules(package).items()}
    assert not any(offending.values()), offending


def test_nonlinear_reads_no_measured_data_files():
    offending = {module: sorted(name for name in names if any(within(name, reader) for reader in FILE_READERS))
                 for module, names in imported_modules("nonlinear").items()}
    assert not any(offending.values()), offending


@pytest.mark.parametrize("package", PACKAGES)
def test_every_module_imports(package):
    for path in sorted((ROOT / package).glob("*.py")):
        importlib.import_module(f"{package}.{path.stem}" if path.stem != "__init__" else package)



def command_imports(package: str) -> dict[str, list[str]]:
    """Module file name -> the command modules (``<package>.commands`` and the command line, ``cli``) it imports,
    for every library module of a package (every module but ``commands``)."""
    return {module: sorted(name for name in names if name.split(".")[-1] == "commands" or within(name, "cli")
                           or any(name == f"{other}.commands" or name.startswith(f"{other}.commands.")
                                  for other in PACKAGES))
            for module, names in imported_modules(package).items() if module != "commands.py"}


@pytest.mark.parametrize("package", LIBRARY)
def test_the_library_imports_no_command_module(package):
    offending = {module: names for module, names in command_imports(package).items() if names}
    assert not offending, offending


def upward_imports(package: str) -> dict[str, list[str]]:
    """Module file name -> the modules of later packages (``PACKAGES``) it imports, for the modules that import
    any."""
    later = PACKAGES[PACKAGES.index(package) + 1:]
    offending = {module: sorted(name for name in names if name.split(".")[0] in later)
                 for module, names in imported_modules(package).items()}
    return {module: names for module, names in offending.items() if names}


@pytest.mark.parametrize("package", PACKAGES)
def test_packages_import_only_the_packages_before_them(package):
    offending = upward_imports(package)
    assert not offending, offending


def name_branches(path: Path, names) -> list[str]:
    """Places in a module that decide on one of ``names`` (friction models, datasets): a comparison with a name
    (``==``, ``in``, against a name or a tuple, list or set of them) or a dict keyed by names, as 'line: source'."""
    source = path.read_text()
    found = []
    for node in ast.walk(ast.parse(source, filename=str(path))):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            constants = [c for operand in operands
                         for c in (operand.elts if isinstance(operand, (ast.Tuple, ast.List, ast.Set)) else [operand])]
        elif isinstance(node, ast.Dict):
            constants = [key for key in node.keys if key is not None]
        else:
            continue
        if any(isinstance(c, ast.Constant) and c.value in names for c in constants):
            found.append(f"{node.lineno}: {ast.get_source_segment(source, node)}")
    return found


def offending_modules(package: str, finder, names, registry: Path | None = None) -> dict:
    """Module -> what ``finder(path, names)`` found in each module of ``package``, the ``registry``'s own module
    aside; modules where it found nothing left out."""
    found = {path.name: finder(path, names) for path in sorted((ROOT / package).glob("*.py")) if path != registry}
    return {module: places for module, places in found.items() if places}


@pytest.mark.parametrize("package", PACKAGES)
def test_no_branch_on_a_friction_model_name_outside_the_registry(package):
    offending = offending_modules(package, name_branches, MODEL_NAMES, ROOT / "nonlinear" / "friction_models.py")
    assert not offending, offending


def module_graph(package: str) -> dict[str, set[str]]:
    """Module stem -> the stems of the same package's modules it imports, absolute or relative, at module level
    or inside a function (``from .a import b``, ``from package.a import b``, ``from package import a``)."""
    stems = {path.stem for path in (ROOT / package).glob("*.py")}
    graph = {}
    for path in sorted((ROOT / package).glob("*.py")):
        found = set()
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.ImportFrom):
                module = (node.module or "") if node.level else (node.module or "").removeprefix(package)
                if node.level == 0 and not within(node.module or "", package):
                    continue
                parts = [part for part in module.split(".") if part]
                found.update(parts[:1] if parts else [alias.name for alias in node.names])
            elif isinstance(node, ast.Import):
                found.update(alias.name.split(".")[1] for alias in node.names
                             if within(alias.name, package) and alias.name != package)
        graph[path.stem] = (found & stems) - {path.stem}
    return graph


def import_cycle(package: str) -> list[str]:
    """The module stems of an import cycle within a package, the first repeated last; [] where there is none."""
    try:
        graphlib.TopologicalSorter(module_graph(package)).prepare()
    except graphlib.CycleError as error:
        return error.args[1]
    return []


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_cycle_within_a_package(package):
    cycle = import_cycle(package)
    assert not cycle, " -> ".join(cycle)


PARALLEL_BACKENDS = ("distributed", "dask", "multiprocessing", "concurrent.futures")
"""What starts workers: only the runners (``pipeline.runners``) use it; the library is passed a runner."""


def parallel_imports(package: str) -> dict[str, list[str]]:
    """Module file name -> the parallel back ends (``PARALLEL_BACKENDS``) it imports, for the modules of a package
    other than ``pipeline/runners.py`` that import any."""
    offending = {module: sorted(name for name in names if any(within(name, backend) for backend in PARALLEL_BACKENDS))
                 for module, names in imported_modules(package).items()
                 if not (package == "pipeline" and module == "runners.py")}
    return {module: names for module, names in offending.items() if names}


@pytest.mark.parametrize("package", PACKAGES)
def test_only_the_runners_start_workers(package):
    offending = parallel_imports(package)
    assert not offending, offending


DATASET_PACKAGES = PACKAGES[PACKAGES.index("study"):]
"""The packages that know the study's datasets (below the study, "beams" is the geometry stage's name)."""


@pytest.mark.parametrize("package", DATASET_PACKAGES)
def test_no_branch_on_a_dataset_name_outside_the_registry(package):
    offending = offending_modules(package, name_branches, DATASET_NAMES, ROOT / "study" / "datasets.py")
    assert not offending, offending


def dataset_strings(path: Path, names) -> list[str]:
    """String constants of a module that name a dataset or a dataset's results folder (``asb``, ``study-asb``,
    ``fit-asb``, also as a component of a path such as ``results/study-asb``), as 'line: source'; docstrings and
    "beams" alone (the geometry stage's folder, build/beams) aside."""
    named = {f"{prefix}{name}" for name in names for prefix in ("study-", "fit-")} | set(names) - {"beams"}
    return [place for place, value in string_constants(path) if named & set(value.split("/"))]


def string_constants(path: Path) -> list[tuple[str, str]]:
    """('line: source', value) of every string constant of a module but its docstrings (module, class, function)."""
    source = path.read_text()
    tree = ast.parse(source, filename=str(path))
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef)) and node.body
                  and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
    return [(f"{node.lineno}: {ast.get_source_segment(source, node)}", node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings]


def test_the_report_finds_the_datasets_through_the_registry():
    """The report knows no dataset by name: its studies and calibrations are those of ``study.datasets``, in the
    folders ``report.studies`` names."""
    offending = offending_modules("report", dataset_strings, DATASET_NAMES)
    assert not offending, offending


EFFECT_PACKAGES = PACKAGES[PACKAGES.index("discrepancy"):]
"""The packages that know the discrepancy loop's effects (below it "linear_damping" is a design's zeta_0 and
"microslip" a regime of a joint; the friction-model registry names the effects each model brings, and
tests/discrepancy/test_effects.py checks them against the effect registry)."""


def effect_strings(path: Path, names) -> list[str]:
    """String constants of a module that are an effect's name, as 'line: source'; docstrings aside."""
    return [place for place, value in string_constants(path) if value in names]


@pytest.mark.parametrize("package", EFFECT_PACKAGES)
def test_no_effect_is_named_outside_the_registry(package):
    offending = offending_modules(package, effect_strings, EFFECT_NAMES, ROOT / "discrepancy" / "effects.py")
    assert not offending, offending



def module_lines(finder, names, module: str):
    """A check of one module against ``names`` (``name_branches``, ``dataset_strings``, ``effect_strings``) as a
    check of a package: package -> the sorted line numbers of its findings in ``module`` of that package."""
    return lambda package: sorted(int(place.split(":")[0]) for place in finder(ROOT / package / module, names))


PLANTED = {
    "command import": ("study", {"exploration.py": "from study.commands import defaults\nfrom study import workflow\n",
                                 "analysis.py": "import cli.console\n",
                                 "commands.py": "from study import workflow\n"},
                       command_imports, {"analysis.py": ["cli.console"],
                                         "exploration.py": ["study.commands", "study.commands.defaults"]}),
    "upward import": ("pipeline", {"commands.py": "from cli import demo\nfrom pipeline import public_data\n",
                                   "config.py": "from study.datasets import DEFAULT_MODELS\n"},
                      upward_imports, {"commands.py": ["cli", "cli.demo"],
                                       "config.py": ["study.datasets", "study.datasets.DEFAULT_MODELS"]}),
    "import cycle": ("reduction", {"craig_bampton.py": "from .superelement import DOFS_PER_PATCH\n",
                                   "superelement.py": "def f():\n    from reduction.craig_bampton import g\n"},
                     import_cycle, ["craig_bampton", "superelement", "craig_bampton"]),
    "pool": ("virtual_experiment", {"hammer_test.py": "import multiprocessing\nfrom pipeline.runners import SERIAL\n",
                                    "commands.py": "def run():\n    from distributed import Client\n"},
             parallel_imports, {"commands.py": ["distributed", "distributed.Client"],
                                "hammer_test.py": ["multiprocessing"]}),
    "branch on a model name": ("nonlinear", {"transient.py": 'law = {"jenkins": 1, "iwan4": 2}\nif model == "iwan5":\n'
                                                             '    pass\nstuck = model in ("iwan4_stuck", "other")\n'
                                                             'name = "iwan4"\n'},
                               module_lines(name_branches, MODEL_NAMES, "transient.py"), [1, 2, 4]),
    "branch on a dataset name": ("study", {"workflow.py": 'if study.dataset == "asb":\n    pass\n'
                                                          'cases = {"beams": "BRB"}\nname = "beams"\n'
                                                          'paper = dataset in ("beams", "other")\n'},
                                 module_lines(name_branches, DATASET_NAMES, "workflow.py"), [1, 3, 5]),
    "dataset string": ("report", {"document.py": '"""The studies of study-asb."""\n'
                                                 'STUDIES = (("beams", "study-beams"), ("asb", "study-asb"))\n'
                                                 'folder = results / "fit-asb"\n'
                                                 'log = "results/study-beams/study.json"\n'
                                                 'meshes = build / "beams"\nfolder = results / f"study-{name}"\n'},
                       module_lines(dataset_strings, DATASET_NAMES, "document.py"), [2, 2, 2, 3, 4]),
    "effect name": ("discrepancy", {"nominal.py": '"""Offsets: stiffness_change and linear_damping."""\n'
                                                  'OFFSETS = {"frequency": "stiffness_change"}\n'
                                                  'if effect in ("microslip", "other"):\n    pass\n'
                                                  'message = "a stiffness_change here"\n'
                                                  'core = effects[-1] == "stuck_core"\n'},
                    module_lines(effect_strings, EFFECT_NAMES, "nominal.py"), [2, 3, 6]),
}
"""Each check on a planted package with violations: name -> (package, its modules (file name -> source), the check
(package -> findings), the findings it must report)."""


@pytest.mark.parametrize(("package", "modules", "check", "expected"), PLANTED.values(), ids=PLANTED.keys())
def test_a_planted_violation_is_found(tmp_path, monkeypatch, package, modules, check, expected):
    (tmp_path / package).mkdir()
    for name, source in modules.items():
        (tmp_path / package / name).write_text(source)
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    assert check(package) == expected
