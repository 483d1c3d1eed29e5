"""``surrogacy data fetch`` against a local HTTP server: every public file fetched under its name with its SHA-256
checked; a damaged file, a transfer that breaks off and an unreachable host each refused with one line, nothing
of the file left behind. The registry is checked against the list of sources beside the shared data."""

import hashlib
import re
import socket
import threading
from functools import partial
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer

import pytest

from locations import SHARED
from cli.console import main as surrogacy
from pipeline.public_data import REGISTRY, PublicFile, fetch

SHARED_DATA = SHARED / "data"


class Handler(SimpleHTTPRequestHandler):
    """Serves a folder; counts the requests; a file named ``*.partial`` is announced whole (its Content-Length
    doubled) and sent half."""

    requests = []

    def log_message(self, *arguments):
        pass

    def do_GET(self):
        Handler.requests.append(self.path)
        if self.path.endswith(".partial"):
            body = (self.directory + self.path)
            data = open(body, "rb").read()
            self.send_response(200)
            self.send_header("Content-Length", str(2 * len(data)))
            self.end_headers()
            self.wfile.write(data)
            self.wfile.flush()
            self.close_connection = True
            return
        super().do_GET()


@pytest.fixture
def serve():
    """serve(folder) -> the base URL of a local HTTP server of ``folder``, stopped after the test."""
    servers = []

    def start(folder):
        Handler.requests = []
        server = ThreadingHTTPServer(("127.0.0.1", 0), partial(Handler, directory=str(folder)))
        threading.Thread(target=server.serve_forever, daemon=True).start()
        servers.append(server)
        return f"http://127.0.0.1:{server.server_address[1]}"

    yield start
    for server in servers:
        server.shutdown()
        server.server_close()


def entry_for(folder, name: str, content: bytes) -> PublicFile:
    """A registry entry for ``content`` (its hash and size), with the file written under ``folder/name``."""
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(content)
    return PublicFile(f"https://example.invalid/{name}", name, hashlib.sha256(content).hexdigest(), len(content))


def listing(folder) -> list[str]:
    return sorted(str(path.relative_to(folder)) for path in folder.rglob("*")) if folder.exists() else []


def test_the_registry_is_the_list_of_sources():
    sources = SHARED_DATA / "SOURCES.md"
    if not sources.is_file():
        pytest.skip(f"the list of sources is absent ({sources})")
    rows = re.findall(r"^\| (https://\S+) \| (\S+) \| ([0-9a-f]{64}) \| (\d+) \|$", sources.read_text(), re.M)
    assert [PublicFile(url, name, sha, int(size)) for url, name, sha, size in rows] == list(REGISTRY)
    assert len({entry.name for entry in REGISTRY}) == len(REGISTRY) == 14


def test_every_file_is_fetched_and_checked_then_kept(tmp_path, serve):
    if not all((SHARED_DATA / entry.name).is_file() for entry in REGISTRY):
        pytest.skip(f"the shared data is absent ({SHARED_DATA})")
    base_url, lines = serve(SHARED_DATA), []
    paths = fetch(tmp_path / "data", base_url, retries=0, progress=False, report=lines.append)
    assert [path.relative_to(tmp_path / "data").as_posix() for path in paths] == [e.name for e in REGISTRY]
    for entry, path in zip(REGISTRY, paths):
        content = path.read_bytes()
        assert len(content) == entry.size and hashlib.sha256(content).hexdigest() == entry.sha256
        assert content == (SHARED_DATA / entry.name).read_bytes()
    assert len(Handler.requests) == len(REGISTRY) and lines[1:] == [
        f"{e.name}: fetched, {e.size:,} bytes, SHA-256 checked" for e in REGISTRY]
    assert listing(tmp_path / "data") == sorted({e.name for e in REGISTRY} | {e.name.split("/")[0] for e in REGISTRY})
    lines.clear()
    fetch(tmp_path / "data", base_url, retries=0, progress=False, report=lines.append)
    assert len(Handler.requests) == len(REGISTRY)  # nothing downloaded again
    assert all(line.startswith(f"{e.name}: present, ") for e, line in zip(REGISTRY, lines[1:]))


def test_a_damaged_file_is_refused_with_one_line_and_nothing_written(tmp_path, serve):
    good = entry_for(tmp_path / "mirror", "asb-backbones/A.mat", b"the measured backbone" * 100)
    damaged = entry_for(tmp_path / "mirror", "asb-reduced-models/B.mat", b"the reduced model" * 100)
    (tmp_path / "mirror" / damaged.name).write_bytes(b"the reduced modeL" * 100)  # one byte changed
    out = tmp_path / "data"
    with pytest.raises(ValueError) as error:
        fetch(out, serve(tmp_path / "mirror"), registry=(good, damaged), retries=0, progress=False,
              report=lambda line: None)
    message = str(error.value)
    assert "\n" not in message and "SHA-256 does not match" in message and damaged.name in message
    assert listing(out) == ["asb-backbones", "asb-backbones/A.mat"]  # the good file, complete; nothing of B


def test_a_transfer_that_breaks_off_leaves_nothing(tmp_path, serve):
    entry = entry_for(tmp_path / "mirror", "chen2022-brb-hammer/H.mat.partial", bytes(range(256)) * 400)
    with pytest.raises(ValueError) as error:
        fetch(tmp_path / "data", serve(tmp_path / "mirror"), registry=(entry,), retries=0, progress=False,
              report=lambda line: None)
    assert "\n" not in str(error.value) and "broke off" in str(error.value)
    assert listing(tmp_path / "data") == []


def test_an_unreachable_host_is_one_line_and_nothing_written(tmp_path):
    with socket.socket() as probe:  # a port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    entry = PublicFile("https://example.invalid/x", "asb-backbones/X.mat", "0" * 64, 1)
    with pytest.raises(ValueError) as error:
        fetch(tmp_path / "data", f"http://127.0.0.1:{port}", registry=(entry,), retries=0, progress=False,
              report=lambda line: None)
    assert "\n" not in str(error.value) and "cannot reach the host" in str(error.value)
    assert str(error.value).startswith(f"http://127.0.0.1:{port}/asb-backbones/X.mat: ")
    assert listing(tmp_path / "data") == []


def test_the_command_fails_with_one_line_and_status_2(tmp_path, capsys):
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    status = surrogacy(["data", "fetch", "--out", str(tmp_path / "data"), "--base-url", f"http://127.0.0.1:{port}",
                        "--retries", "0", "--quiet"])
    error = capsys.readouterr().err.strip()
    assert status == 2 and len(error.splitlines()) == 1
    assert error.startswith("surrogacy data: error: http://127.0.0.1:") and "cannot reach the host" in error
    assert listing(tmp_path / "data") == []
