"""The compiled kernels' cache follows every kernel source: numba itself checks only the file that defines a
kernel, and the kernels inline functions of the other kernel files. Every friction model runs on one compiled
version of each kernel, and the kernels loaded from the cache compute the same bits as where they were compiled."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numba
import pytest

import nonlinear
from locations import ASB_MODELS
from numba.core.caching import UserProvidedCacheLocator

from nonlinear import slip_laws
from nonlinear.compiled_cache import (CACHED_MODULES, KERNEL_MODULES, STAMP, announce_compiling, cache_folder,
                                     drop_stale_kernels, kernels_cached)

SOURCES = Path(nonlinear.__file__).parent


def test_a_change_to_any_kernel_file_drops_every_kernel_s_compiled_code(tmp_path):
    """The CPU kernels and the CUDA ones compiled from them (``nonlinear.qsma_cuda``) alike."""
    for module in CACHED_MODULES:
        shutil.copy(SOURCES / f"{module}.py", tmp_path)
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    compiled = [cache / f"{prefix}{module}.kernel-10.py311.{kind}" for module in CACHED_MODULES
                for prefix in ("", "guf-") for kind in ("nbi", "nbc")]  # guf-: a gufunc's files
    other = cache / "joint.cpython-311.pyc"
    for path in [*compiled, other]:
        path.write_bytes(b"compiled")
    assert sorted(drop_stale_kernels(tmp_path)) == sorted(compiled)  # no stamp yet: nothing is trusted
    assert other.exists() and (cache / STAMP).exists()
    for path in compiled:
        path.write_bytes(b"compiled again")
    assert drop_stale_kernels(tmp_path) == []  # the same sources: the cache is kept
    with open(tmp_path / "dense_linear_algebra.py", "a") as source:  # an edit of the inlined helpers only
        source.write("\n# edited\n")
    assert sorted(drop_stale_kernels(tmp_path)) == sorted(compiled)
    assert not any(path.exists() for path in compiled) and other.exists()


def test_a_cache_in_numba_cache_dir_follows_the_sources_too(tmp_path, monkeypatch):
    """With ``NUMBA_CACHE_DIR`` set numba keeps the compiled code in a subfolder of it named after the sources'
    folder (where numba's own locator puts it), and an edit of one kernel file drops every kernel's code there."""
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "numba-cache"))
    assert str(cache_folder(SOURCES)) == UserProvidedCacheLocator.from_function(
        slip_laws.backbone_force, slip_laws.__file__).get_cache_path()
    sources = tmp_path / "nonlinear"
    sources.mkdir()
    for module in CACHED_MODULES:
        shutil.copy(SOURCES / f"{module}.py", sources)
    cache = cache_folder(sources)
    assert cache.parent == tmp_path / "numba-cache"
    cache.mkdir(parents=True)
    compiled = [cache / f"{prefix}{module}.kernel-10.py311.nbi" for module in CACHED_MODULES for prefix in ("", "guf-")]
    for path in compiled:
        path.write_bytes(b"index")
    assert sorted(drop_stale_kernels(sources)) == sorted(compiled)  # no stamp yet: nothing is trusted
    for path in compiled:
        path.write_bytes(b"index again")
    assert drop_stale_kernels(sources) == []
    with open(sources / "slip_laws.py", "a") as source:  # an edit of the element laws the one-mode kernel compiles
        source.write("\n# edited\n")
    assert sorted(drop_stale_kernels(sources)) == sorted(compiled)


def test_the_kernels_are_cached_only_where_every_kernel_has_its_index(tmp_path, monkeypatch):
    monkeypatch.setattr(numba.config, "CACHE_DIR", "")  # numba's own place: the package's __pycache__
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    assert not kernels_cached(tmp_path)
    for module in KERNEL_MODULES[:-1]:
        (cache / f"{module}.kernel-10.py311.nbi").write_bytes(b"index")
    assert not kernels_cached(tmp_path)  # one kernel still to compile
    (cache / f"{KERNEL_MODULES[-1]}.kernel-10.py311.nbi").write_bytes(b"index")
    assert kernels_cached(tmp_path)


def test_a_cold_cache_is_announced_once(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))  # an empty cache: every kernel to compile
    announce_compiling.cache_clear()
    announce_compiling()
    announce_compiling()
    assert capsys.readouterr().err.count("compiling the QSMA kernels, first use only") == 1
    announce_compiling.cache_clear()


FIRST_USE = """
import json, re
import numpy as np
from nonlinear import qsma_kernel, stuck_modes
from nonlinear.qsma_vectorised import qsma_designs
from test_qsma import TWO_BODY_CASES, two_body_space

space = two_body_space()
for model, design, *_ in TWO_BODY_CASES:
    qsma_designs(space, model, np.array([design]), amplitudes=[1e-6, 1e-5])
    qsma_designs(space, model, np.array([design]), forces=[1e-3, 1e-2])
kernels = (qsma_kernel.solve_levels, qsma_kernel._solve_level, qsma_kernel._newton_step,
           qsma_kernel._factor_with_right_side, stuck_modes.stuck_designs)
print(json.dumps({"specialisations": {kernel.py_func.__name__: len(kernel.signatures) for kernel in kernels},
                  "peak_mib": int(re.search(r"VmHWM:\\s+(\\d+) kB", open("/proc/self/status").read()).group(1)) / 1024}))
"""


@pytest.mark.slow
def test_first_use_compiles_one_version_of_each_kernel_within_the_memory_bound(tmp_path):
    """A process with an empty numba cache (a fresh clone's first study) running every friction model under both
    controls compiles one version of the level solver, its Newton step and the stuck modes (no model's types and
    no literal start value add one, each seconds of compiling), at a peak resident memory (the process's own VmHWM;
    ru_maxrss keeps the forking test worker's, 2.2 GiB after the deep-macroslip tests) below 1.5 GiB (0.36 GiB
    measured; 4.2 GiB where numba inlined every helper into one function). About 30 s on two cores."""
    here = Path(__file__).parent  # for test_qsma's two-body structure, after the project's root
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path),
                       PYTHONPATH=os.pathsep.join([str(SOURCES.parent), str(here), os.environ.get("PYTHONPATH", "")]))
    result = subprocess.run([sys.executable, "-c", FIRST_USE], env=environment, capture_output=True, text=True,
                            check=True)
    measured = json.loads(result.stdout.splitlines()[-1])
    assert measured["specialisations"] == dict.fromkeys(
        ("solve_levels", "_solve_level", "_newton_step", "_factor_with_right_side", "stuck_designs"), 1)
    assert measured["peak_mib"] < 1536


ASB_BACKBONES = """
import hashlib, sys
import numpy as np
from nonlinear.condensation import joint_space, modal_split
from nonlinear.joint import random_designs
from nonlinear.qsma_vectorised import qsma_designs
from reduction.superelement import read_asb_superelement

space = joint_space(read_asb_superelement(sys.argv[1]))
split, digest = modal_split(space), hashlib.sha256()
for model in ("jenkins", "iwan4"):
    designs = random_designs(model, 300, max(space.superelement.patch_groups) + 1, np.random.default_rng(3))
    result = qsma_designs(space, model, designs, amplitudes=np.geomspace(7e-6, 1.1e-4, 8), linear_damping=1e-3,
                          split=split)
    for name in ("force", "frequency", "damping", "joint_displacement", "slip_ratio", "stuck_frequency", "mac"):
        digest.update(np.ascontiguousarray(getattr(result, name)).tobytes())
print(digest.hexdigest())
"""


@pytest.mark.slow
def test_kernels_loaded_from_the_cache_give_the_compiling_process_s_bits(tmp_path):
    """300 random Table 3 designs of two models on the ASB (C1) at 8 levels, computed by a process with an empty
    numba cache (it compiles the kernels) and by a second one that loads them from that cache: the same bits in
    every backbone quantity. With numba's fast-math flags they differed (2e-8 Hz in a frequency), so that a
    study's rows depended on which of its processes compiled first. About 40 s on two cores."""
    path = ASB_MODELS / "MAT_NULLRED_C1.mat"
    if not path.exists():
        pytest.skip(f"ASB reduced model not available at {path} (shared data folder absent)")
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path),
                       PYTHONPATH=os.pathsep.join([str(SOURCES.parent), os.environ.get("PYTHONPATH", "")]))
    digests = [subprocess.run([sys.executable, "-c", ASB_BACKBONES, str(path)], env=environment, capture_output=True,
                              text=True, check=True).stdout.split()[-1] for _ in range(2)]
    assert digests[0] == digests[1]
