"""Shared test fixtures. BLAS runs single-threaded: numpy's and CHOLMOD's threads otherwise compete for the
two cores of the CI machine, each running a pytest-xdist worker (make test)."""

import fcntl
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from geometry.beam_mesh import BeamMesh, read_beam_mesh  # noqa: E402
from geometry.beams import make_beam  # noqa: E402
from geometry.parameters import BEAM_NAMES, BEAMS, MeshParameters  # noqa: E402
from cli.console import main as surrogacy  # noqa: E402
from locations import ASB_MODELS  # noqa: E402
from reduction.superelement import read_asb_superelement  # noqa: E402

BUILD = Path(__file__).resolve().parents[1] / "build"

COARSE = MeshParameters(size=0.0127, lap_size=0.0064, hole_size=0.0032)


@pytest.fixture(scope="session")
def coarse_brb(tmp_path_factory) -> BeamMesh:
    """The BRB meshed at coarse sizes (about 26k quadratic DOF), once per test session."""
    sidecar = make_beam(BEAMS["BRB"], COARSE, tmp_path_factory.mktemp("coarse"), render=False)
    return read_beam_mesh(sidecar.with_suffix(".msh"))


@pytest.fixture(scope="session")
def asb_superelement():
    """Reader of the external ASB reduced models (``MAT_NULLRED_<configuration>.mat`` in ../shared/data beside
    the repository): ``asb_superelement("CD1", coupling=...)`` gives the Superelement. Skips the test, with the
    path in the reason, where the shared data folder is absent."""

    def read(configuration: str, **options):
        path = ASB_MODELS / f"MAT_NULLRED_{configuration}.mat"
        if not path.exists():
            pytest.skip(f"ASB reduced model not available at {path} (shared data folder absent)")
        return read_asb_superelement(path, **options)

    return read


@pytest.fixture(scope="session")
def beam_roms() -> Path:
    """build/rom with the default-mesh superelements of the three beams, built by the pipeline's stages when
    absent (about 6 minutes, once), and the reduction stage run again where its files are of an older format
    (about 1.5 minutes; a no-op when current). The pytest-xdist workers take turns (a lock file beside build/):
    the first builds, the others then find the stages' outputs current."""
    BUILD.mkdir(exist_ok=True)
    with open(BUILD / ".tests.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not all((BUILD / "rom" / f"{beam}.npz").exists() for beam in BEAM_NAMES):
            assert surrogacy(["beams", "--out", str(BUILD / "beams"), "--no-render"]) == 0
            assert surrogacy(["fe", "--beams", str(BUILD / "beams"), "--out", str(BUILD / "fe")]) == 0
        assert surrogacy(["rom", "--beams", str(BUILD / "beams"), "--fe", str(BUILD / "fe"),
                          "--out", str(BUILD / "rom")]) == 0
    return BUILD / "rom"
