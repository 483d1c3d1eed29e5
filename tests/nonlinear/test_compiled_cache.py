"""The compiled kernels' cache follows every kernel source: numba itself checks only the file that defines a
kernel, and the kernels inline functions of the other kernel files."""

import shutil
from pathlib import Path

import numba

import nonlinear
from nonlinear.compiled_cache import (KERNEL_MODULES, STAMP, announce_compiling, drop_stale_kernels,
                                     kernels_cached)

SOURCES = Path(nonlinear.__file__).parent


def test_a_change_to_any_kernel_file_drops_every_kernel_s_compiled_code(tmp_path):
    for module in KERNEL_MODULES:
        shutil.copy(SOURCES / f"{module}.py", tmp_path)
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    compiled = [cache / f"{module}.kernel-10.py311.{kind}" for module in KERNEL_MODULES for kind in ("nbi", "nbc")]
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
