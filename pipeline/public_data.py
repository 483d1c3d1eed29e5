"""The public measured data the pipeline reads, and its download with checked hashes (``surrogacy data fetch``).

Each file is pinned to a commit of its public repository, with its SHA-256 and size; it is saved under the name the
stages expect, relative to the data folder (``asb-backbones/``, ``asb-reduced-models/``, ``chen2022-brb-hammer/``:
the layout ``--data`` and ``--ringdown`` take). The download is pooch's: into a temporary file beside the
destination, moved into place only when its SHA-256 matches; a file already there with the right hash is kept.

Sources. The ASB's measured backbones (EXP_DATA) and reduced models (MATRIX_PREPARE): repository
Nidish96/Computational-Work-For-ASB-Project, which states no licence, so the files are fetched by the user from
their source and never redistributed. The Brake-Reuss beam's hammer-impact ring-down: repository
mattiacenedese/BRBtesting (GPL-3.0); cite W. Chen et al., "Measurement and identification of the nonlinear
dynamics of a jointed structure using full-field data; Part I", MSSP 166 (2022) 108401,
doi:10.1016/j.ymssp.2021.108401.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Callable, NamedTuple

ASB = "https://raw.githubusercontent.com/Nidish96/Computational-Work-For-ASB-Project/43e49256eb3386a137862e728f097421df127f37"
BRB_TESTING = "https://raw.githubusercontent.com/mattiacenedese/BRBtesting/2d42d3a618206da58642674d3287ae34dfc7d5e5"
BASE_URL_VARIABLE = "SURROGACY_DATA_URL"
"""Environment variable naming a server that holds every file under its name here (a mirror), in place of the
sources."""


class PublicFile(NamedTuple):
    """One public file: its pinned URL, its name in the data folder, its SHA-256 (hex) and its size (bytes)."""

    url: str
    name: str
    sha256: str
    size: int


REGISTRY = (
    PublicFile(f"{ASB}/EXP_DATA/ASB_C1_20Nm_BB.mat", "asb-backbones/ASB_C1_20Nm_BB.mat",
               "232929d914519fa3719955b2c684a0d4a7eda072e45b60f1089b32a3459be2c2", 74219),
    PublicFile(f"{ASB}/EXP_DATA/ASB_C2_20Nm_BB.mat", "asb-backbones/ASB_C2_20Nm_BB.mat",
               "8ba53ebc34bbadbe54c055275e4208358e5c7f2d51e97151aa09515b0d299948", 37043),
    PublicFile(f"{ASB}/EXP_DATA/ASB_C3_20Nm_BB.mat", "asb-backbones/ASB_C3_20Nm_BB.mat",
               "31fdce15bb7919b9f15291443591ca9ea4ef5b16b10cebe1e254eedafe74da3d", 68339),
    PublicFile(f"{ASB}/EXP_DATA/ASB_C4_20Nm_BB.mat", "asb-backbones/ASB_C4_20Nm_BB.mat",
               "33c5c0abe7f09de29a1a71eeb2ae84309fe49138ae5ece43fa64b1fd5de08670", 120974),
    PublicFile(f"{ASB}/EXP_DATA/ASB_C4a_20Nm_BB.mat", "asb-backbones/ASB_C4a_20Nm_BB.mat",
               "01c7112d747979da30756f56759026e8861046936ea2911d9deda0d4da808e1c", 63563),
    PublicFile(f"{ASB}/EXP_DATA/ASB_CD1_20Nm_BB.mat", "asb-backbones/ASB_CD1_20Nm_BB.mat",
               "87d25b7d17c461cd9dabb1cd16dabce3db50a038019d909a2d424461ab8d3f4d", 70127),
    PublicFile(f"{ASB}/EXP_DATA/ASB_CD2_20Nm_BB.mat", "asb-backbones/ASB_CD2_20Nm_BB.mat",
               "e922381a5351567ac28efbbf61f86b720fd04847725b9d66efd16fd8dda468dc", 7695),
    PublicFile(f"{ASB}/MATRIX_PREPARE/MAT_NULLRED_C1.mat", "asb-reduced-models/MAT_NULLRED_C1.mat",
               "6c7a55136bfaa617a78e2f3ab87f115c5ff3888acc12aaaf212b0aa388b9eb83", 1615511),
    PublicFile(f"{ASB}/MATRIX_PREPARE/MAT_NULLRED_C2.mat", "asb-reduced-models/MAT_NULLRED_C2.mat",
               "c80eade90aa8808dcd21e97f7820b05e1bf6d675c0a5a812c7530886227b8b3d", 1590066),
    PublicFile(f"{ASB}/MATRIX_PREPARE/MAT_NULLRED_C3.mat", "asb-reduced-models/MAT_NULLRED_C3.mat",
               "1c361ab74a968b88294469ba2bfdd6f476c89db6aeb37579dc4ada60e5d61d17", 1619537),
    PublicFile(f"{ASB}/MATRIX_PREPARE/MAT_NULLRED_C4.mat", "asb-reduced-models/MAT_NULLRED_C4.mat",
               "e1c337dafd9d51640904eaf981a53b77582f9d2f8a51615b52326284c43f8e88", 1623171),
    PublicFile(f"{ASB}/MATRIX_PREPARE/MAT_NULLRED_C4a.mat", "asb-reduced-models/MAT_NULLRED_C4a.mat",
               "42d5e00ced9f2f450e5350ff8fa64570806ea52f6d207b003be1256960d56a87", 1601161),
    PublicFile(f"{ASB}/MATRIX_PREPARE/MAT_NULLRED_CD1.mat", "asb-reduced-models/MAT_NULLRED_CD1.mat",
               "c453a7e3f2d049fce8c65ebc0962f7b0d148150615176791fa45e623aeadf462", 1485298),
    PublicFile(f"{BRB_TESTING}/HammerImpact.mat", "chen2022-brb-hammer/HammerImpact.mat",
               "26b014dac30ed69b0a97aa3bb62bfb240de83e679502c15782465cd60a339189", 979254),
)
"""Every public file the pipeline reads (module docstring)."""


def source_url(entry: PublicFile, base_url: str | None = None) -> str:
    """Where ``entry`` is downloaded from: its pinned URL, or ``<base_url>/<its name>`` on a mirror."""
    return entry.url if not base_url else f"{base_url.rstrip('/')}/{entry.name}"


def fetch(folder: Path, base_url: str | None = None, registry=REGISTRY, retries: int = 2, progress: bool = True,
          report: Callable[[str], None] = print) -> list[Path]:
    """Download every file of ``registry`` into ``folder`` under its name, each SHA-256 checked (a file already
    there with the right hash is kept, one with another is downloaded again); one line per file to ``report``.

    base_url: a mirror holding the files under their names (default ``$SURROGACY_DATA_URL``, else the sources).
    retries: further attempts of a failed download (1 s, 2 s, ... apart). progress: a progress bar per download.
    Returns the files' paths. Raises ValueError, one line naming the URL and the file, at the first file whose
    hash does not match or whose download fails; nothing of that file is left (the files before it are complete
    and checked, and a rerun keeps them).
    """
    import pooch  # pooch and requests only when data is fetched

    pooch.get_logger().setLevel("WARNING")  # one line per file is ours
    folder = Path(folder)
    base_url = base_url if base_url is not None else os.environ.get(BASE_URL_VARIABLE)
    store = pooch.create(path=str(folder), base_url="", registry={e.name: f"sha256:{e.sha256}" for e in registry},
                         urls={e.name: source_url(e, base_url) for e in registry}, retry_if_failed=retries)
    downloader = pooch.HTTPDownloader(progressbar=progress, timeout=60)
    total = sum(entry.size for entry in registry)
    report(f"fetching {len(registry)} public files ({total / 1e6:.1f} MB) into {folder} from "
           f"{base_url or 'their sources'}")
    paths = []
    for entry in registry:
        path = folder / entry.name
        had = {parent for parent in (folder, path.parent) if parent.is_dir()}
        present = path.is_file() and pooch.file_hash(str(path)) == entry.sha256
        try:
            paths.append(Path(store.fetch(entry.name, downloader=downloader)))
        except (ValueError, OSError) as error:  # requests' errors are OSErrors
            for parent in sorted({folder, path.parent} - had, key=lambda p: len(p.parts), reverse=True):
                if parent.is_dir() and not any(parent.iterdir()):
                    parent.rmdir()  # a folder made for this file alone
            raise ValueError(f"{source_url(entry, base_url)}: {failure(error)}; {path} not written") from None
        report(f"{entry.name}: {'present' if present else 'fetched'}, {entry.size:,} bytes, SHA-256 checked")
    return paths


def failure(error: Exception) -> str:
    """What went wrong with a download, in a few words: a hash that does not match, the host unreachable, an HTTP
    error status, or a transfer that broke off."""
    import requests

    if isinstance(error, ValueError) and "hash" in str(error):
        return "its SHA-256 does not match the registry's (the file at the source differs, or arrived damaged)"
    if isinstance(error, requests.exceptions.HTTPError) and error.response is not None:
        return f"HTTP {error.response.status_code} {error.response.reason}"
    if isinstance(error, requests.exceptions.ChunkedEncodingError):
        return "the download broke off before the end of the file"
    if isinstance(error, requests.exceptions.ConnectionError):
        reason = re.search(r"\[Errno -?\d+\] [^'\")]+", str(error))
        return f"cannot reach the host ({reason.group(0) if reason else type(error).__name__})"
    if isinstance(error, requests.exceptions.Timeout):
        return "the host did not answer in time"
    return f"{type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}"
