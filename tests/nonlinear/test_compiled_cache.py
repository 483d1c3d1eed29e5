"""The compiled kernels' cache follows every kernel source: numba itself checks only the file that defines a
kernel, and the kernels inline functions of the other kernel files."""

import shutil
from pathlib import Path

import nonlinear
from nonlinear.compiled_cache import KERNEL_MODULES, STAMP, drop_stale_kernels

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
