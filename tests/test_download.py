"""Downloading CMU trials, against a local HTTP server that mimics mocap.cs.cmu.edu.

The server runs on 127.0.0.1 and serves a folder of ASF/AMC files under CMU's URL layout,
``/subjects/<SS>/<file>``, with ``Range`` support. No test contacts the internet.
"""
import http.server
import re
import socket
import threading

import pytest

from motionlab import download

from conftest import CMU_DIR

SHARED = CMU_DIR.parent / "cmu_asfamc"
requires_asfamc = pytest.mark.skipif(
    not (SHARED / "16.asf").is_file(), reason=f"CMU ASF/AMC files not found in {SHARED}")


class MirrorHandler(http.server.BaseHTTPRequestHandler):
    """Serves ``server.root`` as CMU does; ``server.mode`` makes it misbehave on purpose:
    ``"ignore-range"`` (always the whole file), ``"truncate"`` (announce the whole file, send
    half), ``"html"`` (an HTML page for every file)."""

    def do_GET(self):
        server = self.server
        server.log.append((self.path, self.headers.get("Range")))
        match = re.fullmatch(r"/subjects/(\d+)/((\d+)[_.][\w.]+)", self.path)
        file = server.root / match.group(2) if match and match.group(1) == match.group(3) else None
        if server.mode == "html":
            return self.send(200, b"<!DOCTYPE html><html><body>Server error</body></html>")
        if file is None or not file.is_file():
            return self.send(404, b"<html><body>404 Not Found</body></html>")
        body = file.read_bytes()
        wanted = re.fullmatch(r"bytes=(\d+)-", self.headers.get("Range") or "")
        if wanted and server.mode != "ignore-range":
            start = int(wanted.group(1))
            if start >= len(body):
                return self.send(416, b"", {"Content-Range": f"bytes */{len(body)}"})
            content_range = f"bytes {start}-{len(body) - 1}/{len(body)}"
            return self.send(206, body[start:], {"Content-Range": content_range})
        if server.mode == "truncate":
            return self.send(200, body[:len(body) // 2], length=len(body))
        self.send(200, body)

    def send(self, status, body, headers=None, length=None):
        self.send_response(status)
        self.send_header("Content-Length", str(len(body) if length is None else length))
        for key, value in (headers or {}).items():
            self.send_header(key, value)
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):                 # keep pytest's output clean
        pass


@pytest.fixture
def serve():
    """``serve(folder)`` starts a mirror of ``folder``; returns the server (``.url``,
    ``.log`` of ``(path, Range)`` per request, ``.mode``). Stopped after the test."""
    servers = []

    def start(root):
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), MirrorHandler)
        server.root, server.log, server.mode = root, [], "normal"
        server.url = f"http://127.0.0.1:{server.server_port}"
        thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True)
        thread.start()
        servers.append((server, thread))
        return server

    yield start
    for server, thread in servers:
        server.shutdown()
        server.server_close()
        thread.join()


@pytest.fixture
def fake_cmu(tmp_path):
    """A folder with a tiny skeleton and trial in CMU's format (no shared data needed)."""
    root = tmp_path / "site"
    root.mkdir()
    (root / "16.asf").write_text("# AST/ASF file\n:version 1.10\n:name VICON\n")
    (root / "16_15.amc").write_text("#!OML:ASF 16.asf\n:FULLY-SPECIFIED\n:DEGREES\n1\nroot 0 0 0 0 0 0\n")
    return root


def run(server, trials, dest, **kwargs):
    return download.download_cmu(trials, dest=dest, base_url=server.url, progress=False, **kwargs)


# --------------------------------------------------------------------------- names

@pytest.mark.parametrize("trial, name", [("16_15", "16_15"), ((16, 15), "16_15"), ("2_1", "02_01"),
                                         ((127, 3), "127_03"), (["09", "12"][0] + "_12", "09_12")])
def test_trial_names(trial, name):
    assert download.trial_name(trial) == name


@pytest.mark.parametrize("bad", ["16-15", "abc", "16_15.amc", "16_", (16,), (16, "15"), (0, 1), 1615,
                                 (True, 2), "1234_01"])
def test_bad_trial_names_are_value_errors(tmp_path, bad):
    with pytest.raises(ValueError, match="trial: "):
        download.download_cmu([bad], dest=tmp_path, base_url="http://127.0.0.1:1", progress=False)
    assert not any(tmp_path.iterdir())                 # checked before anything is fetched


def test_trial_urls_follow_cmus_layout():
    assert download.trial_urls((2, 1)) == ("http://mocap.cs.cmu.edu/subjects/02/02_01.amc",
                                           "http://mocap.cs.cmu.edu/subjects/02/02.asf")
    assert download.trial_urls("127_03", "http://mirror/x/")[0] == "http://mirror/x/subjects/127/127_03.amc"


def test_default_trials_are_distinct_locomotion_trials():
    assert len(set(download.DEFAULT_TRIALS)) == len(download.DEFAULT_TRIALS) == 55
    assert all(download.trial_name(t) == t for t in download.DEFAULT_TRIALS)
    assert "09_10" not in download.DEFAULT_TRIALS
    if CMU_DIR.is_dir():
        assert set(download.DEFAULT_TRIALS) == {p.stem for p in CMU_DIR.glob("*.bvh")}


def test_content_checks():
    assert download.looks_like_amc(b"#!OML:ASF x\r\n:FULLY-SPECIFIED\r\n:DEGREES\r\n1\r\n")
    assert download.looks_like_amc(b"1\nroot 0 0 0\n")
    assert not download.looks_like_amc(b"<!DOCTYPE html><html>")
    assert download.looks_like_asf(b"# AST/ASF\n:version 1.10\n")
    assert not download.looks_like_asf(b"<html><body>404</body></html>")


# --------------------------------------------------------------------------- downloads

@requires_asfamc
def test_downloads_trials_and_skeletons_byte_identical(serve, tmp_path):
    server = serve(SHARED)
    dest = tmp_path / "cmu"
    paths = run(server, ["16_15", (16, 35), "09_01"], dest)
    assert paths == [dest / "16_15.amc", dest / "16_35.amc", dest / "09_01.amc"]
    assert sorted(p.name for p in dest.iterdir()) == ["09.asf", "09_01.amc", "16.asf", "16_15.amc",
                                                      "16_35.amc"]
    for path in dest.iterdir():
        assert path.read_bytes() == (SHARED / path.name).read_bytes(), path.name
    assert sorted(path for path, _ in server.log) == [
        "/subjects/09/09.asf", "/subjects/09/09_01.amc", "/subjects/16/16.asf",
        "/subjects/16/16_15.amc", "/subjects/16/16_35.amc"]          # each skeleton once

    server.log.clear()
    assert run(server, ["16_15", "16_35", "09_01"], dest) == paths
    assert server.log == []                                           # nothing fetched again


@requires_asfamc
def test_downloaded_trial_loads(serve, tmp_path):
    from motionlab import asfamc
    positions, fps = asfamc.load_locomotion(run(serve(SHARED), ["16_15"], tmp_path)[0])
    assert positions.shape == (471, 21, 3) and fps == 120


@requires_asfamc
def test_resumes_a_partial_download_with_a_range_request(serve, tmp_path):
    server = serve(SHARED)
    original = (SHARED / "16_15.amc").read_bytes()
    (tmp_path / "16.asf").write_bytes((SHARED / "16.asf").read_bytes())
    (tmp_path / "16_15.amc.part").write_bytes(original[:100_000])
    run(server, ["16_15"], tmp_path)
    assert server.log == [("/subjects/16/16_15.amc", "bytes=100000-")]
    assert (tmp_path / "16_15.amc").read_bytes() == original
    assert not (tmp_path / "16_15.amc.part").exists()


@requires_asfamc
def test_a_broken_transfer_fails_and_the_next_run_resumes_it(serve, tmp_path):
    server = serve(SHARED)
    server.mode = "truncate"
    original = (SHARED / "16_15.amc").read_bytes()
    (tmp_path / "16.asf").write_bytes((SHARED / "16.asf").read_bytes())
    with pytest.raises(download.DownloadError, match=r"16_15\.amc: received \d+ of 361470 bytes; run again"):
        run(server, ["16_15"], tmp_path)
    half = (tmp_path / "16_15.amc.part").stat().st_size
    assert 0 < half < len(original) and not (tmp_path / "16_15.amc").exists()
    server.mode, server.log = "normal", []
    run(server, ["16_15"], tmp_path)
    assert server.log == [("/subjects/16/16_15.amc", f"bytes={half}-")]
    assert (tmp_path / "16_15.amc").read_bytes() == original


@requires_asfamc
@pytest.mark.parametrize("mode, part", [("ignore-range", b"garbage that is not a prefix"),
                                        ("normal", None)])
def test_restarts_when_the_range_is_ignored_or_unsatisfiable(serve, tmp_path, mode, part):
    server = serve(SHARED)
    server.mode = mode
    original = (SHARED / "16_15.amc").read_bytes()
    (tmp_path / "16.asf").write_bytes((SHARED / "16.asf").read_bytes())
    (tmp_path / "16_15.amc.part").write_bytes(part or original + b"too long")   # too long: HTTP 416
    run(server, ["16_15"], tmp_path)
    assert (tmp_path / "16_15.amc").read_bytes() == original
    assert server.log[0][1] is not None                               # it did ask for a range


# --------------------------------------------------------------------------- failures

def test_missing_trial_is_an_error_naming_the_url(serve, fake_cmu, tmp_path):
    server = serve(fake_cmu)
    with pytest.raises(ValueError, match=re.escape(f"{server.url}/subjects/16/16_99.amc: not found")):
        run(server, ["16_15", "16_99"], tmp_path)
    assert (tmp_path / "16_15.amc").is_file() and not (tmp_path / "16_99.amc").exists()
    with pytest.raises(ValueError, match=re.escape(f"{server.url}/subjects/17/17.asf: not found")):
        run(server, ["17_01"], tmp_path)


def test_an_html_page_is_not_taken_for_a_file(serve, fake_cmu, tmp_path):
    server = serve(fake_cmu)
    server.mode = "html"
    with pytest.raises(ValueError, match=re.escape(f"{server.url}/subjects/16/16.asf: expected a CMU ASF "
                                                   "file, the server sent an HTML page")):
        run(server, ["16_15"], tmp_path / "out")
    assert list((tmp_path / "out").iterdir()) == []                   # nothing half-written left


def closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_an_unreachable_site_says_the_machine_seems_offline(tmp_path):
    url = f"http://127.0.0.1:{closed_port()}"
    with pytest.raises(download.DownloadError, match=re.escape(f"could not reach {url}/subjects/16/16.asf")
                       + r".*seems to be offline"):
        download.download_cmu(["16_15"], dest=tmp_path, base_url=url, progress=False, timeout=5)


def test_a_silent_server_times_out_with_the_same_message(tmp_path):
    with socket.socket() as listener:                  # accepts connections, never answers
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        url = f"http://127.0.0.1:{listener.getsockname()[1]}"
        with pytest.raises(download.DownloadError, match=r"could not reach .*timed out.*seems to be offline"):
            download.download_cmu(["16_15"], dest=tmp_path, base_url=url, progress=False, timeout=0.5)


def test_command_line(serve, fake_cmu, tmp_path, capsys):
    server = serve(fake_cmu)
    dest = tmp_path / "out"
    assert download.main(["16_15", "--dest", str(dest), "--base-url", server.url, "--quiet"]) == 0
    assert f"1 trial (.amc, with the subjects' .asf skeletons) in {dest.resolve()}" in capsys.readouterr().out
    assert (dest / "16_15.amc").read_bytes() == (fake_cmu / "16_15.amc").read_bytes()
    assert download.main(["16_99", "--dest", str(dest), "--base-url", server.url, "--quiet"]) == 1
    assert "error: " + f"{server.url}/subjects/16/16_99.amc: not found" in capsys.readouterr().err
