"""Downloading CMU trials, against a local HTTP server that mimics mocap.cs.cmu.edu.

The server runs on 127.0.0.1 and serves a folder of ASF/AMC files under CMU's URL layout,
``/subjects/<SS>/<file>``, with ``ETag``, ``Last-Modified``, ``Range`` and ``If-Range``
support, and can misbehave on purpose. The files are the real CMU files of
``../shared/mocap/cmu_asfamc`` (trials cut to their first 50 frames, at a frame boundary,
to keep the tests fast). No test contacts the internet.
"""
import email.utils
import hashlib
import http.server
import json
import re
import shutil
import socket
import threading
import warnings

import pytest

from motionlab import download

from conftest import CMU_DIR

SHARED = CMU_DIR.parent / "cmu_asfamc"
MISSING = f"CMU ASF/AMC files not found in {SHARED}"
requires_asfamc = pytest.mark.skipif(not (SHARED / "16.asf").is_file(), reason=MISSING)


class MirrorHandler(http.server.BaseHTTPRequestHandler):
    """Serves ``server.root`` as CMU does (HTTP/1.0: the connection closes after each
    answer). ``server.mode`` makes it misbehave on purpose:

    * ``"ignore-range"``: always the whole file (200);
    * ``"ignore-if-range"``: honours ``Range`` even when ``If-Range`` names another version;
    * ``"drop"``: announces the length of the whole answer, sends half of it, hangs up;
    * ``"no-length"``: no ``Content-Length``, sends the first ``server.cut`` bytes (all if
      ``None``), hangs up;
    * ``"html"``: an HTML page for every file.

    ``server.validators = False`` leaves out ``ETag`` and ``Last-Modified``.
    """

    def do_GET(self):
        server = self.server
        server.log.append((self.path, self.headers.get("Range"), self.headers.get("If-Range")))
        match = re.fullmatch(r"/subjects/(\d+)/((\d+)[_.][\w.]+)", self.path)
        file = server.root / match.group(2) if match and match.group(1) == match.group(3) else None
        if server.mode == "html":
            return self.send(200, b"<!DOCTYPE html><html><body>Server error</body></html>")
        if file is None or not file.is_file():
            return self.send(404, b"<html><body>404 Not Found</body></html>")
        body = file.read_bytes()
        validators = {} if not server.validators else {
            "ETag": f'"{hashlib.sha256(body).hexdigest()[:16]}"',
            "Last-Modified": email.utils.formatdate(file.stat().st_mtime, usegmt=True)}
        wanted = re.fullmatch(r"bytes=(\d+)-", self.headers.get("Range") or "")
        if_range = self.headers.get("If-Range")
        same = if_range is None or if_range in validators.values() or server.mode == "ignore-if-range"
        if wanted and same and server.mode != "ignore-range":
            start = int(wanted.group(1))
            if start >= len(body):
                return self.send(416, b"", {"Content-Range": f"bytes */{len(body)}"})
            content_range = f"bytes {start}-{len(body) - 1}/{len(body)}"
            return self.send(206, body[start:], {"Content-Range": content_range, **validators})
        self.send(200, body, validators)

    def send(self, status, body, headers=None):
        mode = self.server.mode
        self.send_response(status)
        if mode != "no-length":
            self.send_header("Content-Length", str(len(body)))
        for key, value in (headers or {}).items():
            self.send_header(key, value)
        self.end_headers()
        if mode == "drop" and status in (200, 206):
            body = body[:len(body) // 2]
        elif mode == "no-length" and self.server.cut is not None:
            body = body[:self.server.cut]
        self.wfile.write(body)

    def log_message(self, *args):                 # keep pytest's output clean
        pass


@pytest.fixture
def serve():
    """``serve(folder)`` starts a mirror of ``folder``; returns the server (``.url``,
    ``.log`` of ``(path, Range, If-Range)`` per request, ``.mode``, ``.cut``,
    ``.validators``). Stopped
    after the test."""
    servers = []

    def start(root):
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), MirrorHandler)
        server.root, server.log, server.mode, server.cut, server.validators = root, [], "normal", None, True
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


def first_frames(data: bytes, frames: int) -> bytes:
    """The start of an AMC file up to the end of frame ``frames`` (a frame boundary)."""
    match = re.search(rb"\n%d\r?\n" % (frames + 1), data)
    return data[:match.start() + 1]


@pytest.fixture
def site(tmp_path_factory):
    """A mirror folder of real CMU files: skeletons 16 and 09, trials 16_15, 16_35 and
    09_01 cut to their first 50 frames."""
    if not (SHARED / "16.asf").is_file():
        pytest.skip(MISSING)
    root = tmp_path_factory.mktemp("site")                   # not in tmp_path: that is the dest
    for name in ("16.asf", "09.asf"):
        shutil.copyfile(SHARED / name, root / name)
    for name in ("16_15", "16_35", "09_01"):
        (root / f"{name}.amc").write_bytes(first_frames((SHARED / f"{name}.amc").read_bytes(), 50))
    return root


def run(server, trials, dest, **kwargs):
    return download.download_cmu(trials, dest=dest, base_url=server.url, progress=False, **kwargs)


def manifest(dest):
    return json.loads((dest / "manifest.json").read_text())


def leftovers(dest):
    """Names of half-done files in ``dest``."""
    return sorted(p.name for p in dest.iterdir() if p.name.endswith((".part", ".part.json", ".tmp")))


def drop_midway(server, trials, dest):
    """A download whose connection drops mid-body: it fails and leaves a ``.part``."""
    mode, server.mode = server.mode, "drop"
    with pytest.raises(download.DownloadError, match=r"received \d+ of \d+ bytes .*run again to resume"):
        run(server, trials, dest)
    server.mode = mode


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


@requires_asfamc
def test_check_amc_wants_every_frame_complete(tmp_path):
    data = first_frames((SHARED / "16_15.amc").read_bytes(), 3)
    good = tmp_path / "good.amc"
    good.write_bytes(data)
    assert download.check_amc(good, SHARED / "16.asf").n_frames == 3
    short = tmp_path / "short.amc"
    short.write_bytes(data[:data.rindex(b"\nlfoot")] + b"\n")      # frame 3 lacks lfoot, ltoes
    with pytest.raises(ValueError, match=r"short\.amc:\d+: frame 3 lacks 2 of 29 bones \(lfoot, ltoes\)"):
        download.check_amc(short, SHARED / "16.asf")
    short.write_bytes(data[:-3])                                  # cut mid-line
    with pytest.raises(ValueError, match="no line break: the file was cut short"):
        download.check_amc(short, SHARED / "16.asf")


@requires_asfamc
def test_check_amc_refuses_what_the_reader_only_warns_about(tmp_path):
    data = first_frames((SHARED / "16_15.amc").read_bytes(), 3)
    path = tmp_path / "bad.amc"
    path.write_bytes(data[:data.rindex(b"ltoes")] + b"ltoes\n")     # the last bone without values
    with warnings.catch_warnings():
        warnings.simplefilter("error")                              # none may leak out either
        with pytest.raises(ValueError, match=r"bad\.amc:\d+: "):
            download.check_amc(path, SHARED / "16.asf")


# --------------------------------------------------------------------------- downloads

@requires_asfamc
def test_downloads_trials_and_skeletons_byte_identical_with_a_manifest(serve, tmp_path):
    server = serve(SHARED)                                        # the real, whole files
    dest = tmp_path / "cmu"
    paths = run(server, ["16_15", (16, 35), "09_01"], dest)
    assert paths == [dest / "16_15.amc", dest / "16_35.amc", dest / "09_01.amc"]
    files = ["09.asf", "09_01.amc", "16.asf", "16_15.amc", "16_35.amc"]
    assert sorted(p.name for p in dest.iterdir()) == files + ["manifest.json"]
    for name in files:
        original = (SHARED / name).read_bytes()
        assert (dest / name).read_bytes() == original, name
        entry = manifest(dest)[name]
        assert entry["size"] == len(original)
        assert entry["sha256"] == hashlib.sha256(original).hexdigest()
        assert entry["url"] == f"{server.url}/subjects/{name[:2]}/{name}"
        assert entry["origin"] == "downloaded" and entry["recorded"]
    assert sorted(path for path, *_ in server.log) == [
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


@pytest.mark.parametrize("validators", [True, False])
def test_a_dropped_connection_fails_and_the_next_run_resumes_it(serve, site, tmp_path, validators):
    server = serve(site)
    server.validators = validators           # without: resumed on the recorded size alone
    original = (site / "16_15.amc").read_bytes()
    shutil.copyfile(site / "16.asf", tmp_path / "16.asf")
    drop_midway(server, ["16_15"], tmp_path)
    half = (tmp_path / "16_15.amc.part").stat().st_size
    assert 0 < half < len(original) and not (tmp_path / "16_15.amc").exists()
    assert "16_15.amc" not in manifest(tmp_path)

    server.log.clear()
    run(server, ["16_15"], tmp_path)
    [(path, asked, if_range)] = server.log
    assert (path, asked) == ("/subjects/16/16_15.amc", f"bytes={half}-")
    assert (if_range is None) == (not validators)
    assert (tmp_path / "16_15.amc").read_bytes() == original
    assert leftovers(tmp_path) == []
    assert manifest(tmp_path)["16_15.amc"]["sha256"] == hashlib.sha256(original).hexdigest()


@pytest.mark.parametrize("record", [False, True])
def test_a_part_left_by_another_trial_is_not_spliced(serve, site, tmp_path, record):
    server = serve(site)
    shutil.copyfile(site / "16.asf", tmp_path / "16.asf")
    drop_midway(server, ["16_35"], tmp_path)                 # 16_35.amc.part and its record
    (tmp_path / "16_35.amc.part").rename(tmp_path / "16_15.amc.part")
    if record:                                               # recorded, but for 16_35's URL
        (tmp_path / "16_35.amc.part.json").rename(tmp_path / "16_15.amc.part.json")
    else:                                                    # no record: origin unknown
        (tmp_path / "16_35.amc.part.json").unlink()
    server.log.clear()
    run(server, ["16_15"], tmp_path)
    assert server.log == [("/subjects/16/16_15.amc", None, None)]        # started over
    assert (tmp_path / "16_15.amc").read_bytes() == (site / "16_15.amc").read_bytes()
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("mode", ["normal", "ignore-if-range"])
def test_a_part_of_a_file_that_changed_on_the_server_is_not_spliced(serve, site, tmp_path, mode):
    server = serve(site)
    shutil.copyfile(site / "16.asf", tmp_path / "16.asf")
    drop_midway(server, ["16_15"], tmp_path)
    changed = first_frames((SHARED / "16_15.amc").read_bytes(), 60)     # a new version
    (site / "16_15.amc").write_bytes(changed)
    server.mode, server.log = mode, []
    run(server, ["16_15"], tmp_path)
    assert server.log[0][1:] != (None, None)                 # it asked to resume, If-Range and all
    assert (tmp_path / "16_15.amc").read_bytes() == changed
    assert len(server.log) == (1 if mode == "normal" else 2)  # 200 whole; or a wrong 206, refused


@pytest.mark.parametrize("mode, extra", [("ignore-range", b""), ("normal", b"x" * 100_000)])
def test_restarts_when_the_range_is_ignored_or_unsatisfiable(serve, site, tmp_path, mode, extra):
    server = serve(site)
    original = (site / "16_15.amc").read_bytes()
    shutil.copyfile(site / "16.asf", tmp_path / "16.asf")
    drop_midway(server, ["16_15"], tmp_path)
    with open(tmp_path / "16_15.amc.part", "ab") as part:
        part.write(extra)                                     # past the end: HTTP 416
    server.mode, server.log = mode, []
    run(server, ["16_15"], tmp_path)
    assert (tmp_path / "16_15.amc").read_bytes() == original
    assert server.log[0][1] is not None                       # it did ask for a range
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("damage", ["same size", "shorter", "longer"])
def test_a_file_damaged_after_download_is_reported_and_fetched_again(serve, site, tmp_path, damage):
    server = serve(site)
    run(server, ["16_15"], tmp_path)
    path, original = tmp_path / "16_15.amc", (site / "16_15.amc").read_bytes()
    changed = {"same size": original.replace(b"root ", b"root 9", 1)[:len(original)],
               "shorter": original[:len(original) // 2], "longer": original + b"1\n"}[damage]
    path.write_bytes(changed)
    server.log.clear()
    with pytest.warns(download.DownloadWarning, match=r"16_15\.amc: its (size|content) changed since "
                      r"it was recorded in manifest\.json .*fetching it again"):
        run(server, ["16_15"], tmp_path)
    assert [p for p, *_ in server.log] == ["/subjects/16/16_15.amc"]
    assert path.read_bytes() == original


def test_a_damaged_skeleton_is_fetched_again(serve, site, tmp_path):
    server = serve(site)
    run(server, ["16_15"], tmp_path)
    (tmp_path / "16.asf").write_bytes((site / "16.asf").read_bytes()[:3000])
    with pytest.warns(download.DownloadWarning, match=r"16\.asf: its size changed"):
        run(server, ["16_15"], tmp_path)
    assert (tmp_path / "16.asf").read_bytes() == (site / "16.asf").read_bytes()


def test_a_file_not_in_the_manifest_is_parsed_before_it_is_trusted(serve, site, tmp_path):
    server = serve(site)
    for name in ("16.asf", "16_15.amc", "16_35.amc"):
        shutil.copyfile(site / name, tmp_path / name)
    broken = (site / "16_35.amc").read_bytes()
    (tmp_path / "16_35.amc").write_bytes(broken[:broken.rindex(b"\nrfoot") + 1])   # a frame cut short
    with pytest.warns(download.DownloadWarning, match=r"16_35\.amc: it is not in manifest\.json and is "
                      r"not a valid AMC file \(.*frame 50 lacks .*\); fetching it again"):
        run(server, ["16_15", "16_35"], tmp_path)
    assert [p for p, *_ in server.log] == ["/subjects/16/16_35.amc"]      # the good ones kept
    for name in ("16.asf", "16_15.amc", "16_35.amc"):
        assert (tmp_path / name).read_bytes() == (site / name).read_bytes()
    origins = {name: entry["origin"] for name, entry in manifest(tmp_path).items()}
    assert origins == {"16.asf": "found in the folder, parsed", "16_15.amc": "found in the folder, parsed",
                       "16_35.amc": "downloaded"}


# --------------------------------------------------------------------------- failures

def test_a_whole_body_without_content_length_is_taken(serve, site, tmp_path):
    server = serve(site)
    server.mode = "no-length"
    run(server, ["16_15"], tmp_path)
    assert (tmp_path / "16_15.amc").read_bytes() == (site / "16_15.amc").read_bytes()


@pytest.mark.parametrize("file, cut, reason", [
    ("16_15.amc", "mid-line", r"16_15\.amc\.part: the last line has no line break"),
    ("16_15.amc", "end of a line", r"16_15\.amc\.part:\d+: frame 30 lacks 1 of 29 bones \(ltoes\)"),
    ("16.asf", "end of a line", r"16\.asf\.part:\d+: .*"),
])
def test_a_body_cut_short_without_content_length_is_refused(serve, site, tmp_path, file, cut, reason):
    server = serve(site)
    if file.endswith(".amc"):
        shutil.copyfile(site / "16.asf", tmp_path / "16.asf")
    data = (site / file).read_bytes()
    if file.endswith(".amc"):                                 # the end of frame 30's lfoot line
        end = data.rindex(b"\n", 0, data.index(b"\n31\n"))
    else:                                                     # a line in the middle of the file
        end = data.index(b"\n", len(data) // 2)
    server.mode, server.cut = "no-length", end - 3 if cut == "mid-line" else end + 1
    url = f"{server.url}/subjects/16/{file}"
    with pytest.raises(download.DownloadError, match=re.escape(f"trial 16_15: {url}: not a complete, "
                       f"valid {file[-3:].upper()} file, so it was not kept: ") + ".*" + reason):
        run(server, ["16_15"], tmp_path)
    assert not (tmp_path / file).exists() and leftovers(tmp_path) == []
    assert file not in (manifest(tmp_path) if (tmp_path / "manifest.json").exists() else {})


@pytest.mark.parametrize("text", [":FULLY-SPECIFIED\n<!DOCTYPE html>\n<html><body>Oops</body></html>\n",
                                  "1\n<html><body>Oops</body></html>\n"])
def test_an_amc_that_is_html_after_its_first_line_is_refused(serve, site, tmp_path, text):
    server = serve(site)
    (site / "16_15.amc").write_text(text)
    with pytest.raises(download.DownloadError, match=r"trial 16_15: .*16_15\.amc: not a complete, valid AMC "
                       r"file, so it was not kept: .*16_15\.amc\.part:\d+: "):
        run(server, ["16_15"], tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["16.asf", "manifest.json"]


def test_an_amc_whose_skeleton_is_missing_on_the_server_is_refused(serve, site, tmp_path):
    server = serve(site)
    (site / "16.asf").unlink()
    with pytest.raises(download.DownloadError, match=re.escape(
            f"trial 16_15: {server.url}/subjects/16/16.asf: not found on the server (HTTP 404); "
            "the trial needs this skeleton, 16.asf")):
        run(server, ["16_15"], tmp_path)
    assert [p for p, *_ in server.log] == ["/subjects/16/16.asf"]     # the AMC is not even asked for
    assert list(tmp_path.iterdir()) == []


def test_missing_trial_is_an_error_naming_the_url(serve, site, tmp_path):
    server = serve(site)
    with pytest.raises(ValueError, match=re.escape(f"trial 16_99: {server.url}/subjects/16/16_99.amc: "
                                                   "not found on the server (HTTP 404); is that trial")):
        run(server, ["16_15", "16_99"], tmp_path)
    assert (tmp_path / "16_15.amc").is_file() and not (tmp_path / "16_99.amc").exists()
    with pytest.raises(ValueError, match=re.escape(f"{server.url}/subjects/17/17.asf: not found")):
        run(server, ["17_01"], tmp_path)


def test_an_html_page_is_not_taken_for_a_file(serve, site, tmp_path):
    server = serve(site)
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
    with pytest.raises(download.DownloadError, match=re.escape(f"trial 16_15: could not reach {url}/subjects/16/16.asf")
                       + r".*seems to be offline"):
        download.download_cmu(["16_15"], dest=tmp_path, base_url=url, progress=False, timeout=5)
    assert list(tmp_path.iterdir()) == []


def test_a_silent_server_times_out_with_the_same_message(tmp_path):
    with socket.socket() as listener:                  # accepts connections, never answers
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        url = f"http://127.0.0.1:{listener.getsockname()[1]}"
        with pytest.raises(download.DownloadError, match=r"could not reach .*timed out.*seems to be offline"):
            download.download_cmu(["16_15"], dest=tmp_path, base_url=url, progress=False, timeout=0.5)


def test_command_line(serve, site, tmp_path, capsys):
    server = serve(site)
    dest = tmp_path / "out"
    assert download.main(["16_15", "--dest", str(dest), "--base-url", server.url, "--quiet"]) == 0
    assert f"1 trial (.amc, with the subjects' .asf skeletons) in {dest.resolve()}" in capsys.readouterr().out
    assert (dest / "16_15.amc").read_bytes() == (site / "16_15.amc").read_bytes()
    (dest / "16_15.amc").write_bytes(b"damaged")
    assert download.main(["16_15", "--dest", str(dest), "--base-url", server.url, "--quiet"]) == 0
    assert "warning: " + f"{dest / '16_15.amc'}: its size changed" in capsys.readouterr().err
    assert download.main(["16_99", "--dest", str(dest), "--base-url", server.url, "--quiet"]) == 1
    assert "error: trial 16_99: " + f"{server.url}/subjects/16/16_99.amc: not found" in capsys.readouterr().err


def test_the_full_locomotion_set_is_a_documented_list_of_distinct_trials(monkeypatch):
    from motionlab.cmu_locomotion import LOCOMOTION_FULL
    names = [trial for trial, _ in LOCOMOTION_FULL]
    assert len(names) == len(set(names)) == 685
    assert all(download.trial_name(t) == t and description.strip() for t, description in LOCOMOTION_FULL)
    assert names == sorted(names, key=lambda t: tuple(map(int, t.split("_"))))
    sets = download.trial_sets()
    assert sets["course"] == download.DEFAULT_TRIALS and sets["locomotion-full"] == tuple(names)
    asked = []
    monkeypatch.setattr(download, "download_cmu", lambda trials, *a, **k: asked.append(trials) or [])
    assert download.main(["--set", "locomotion-full", "--quiet"]) == 0
    assert asked == [tuple(names)]
    with pytest.raises(SystemExit):
        download.main(["16_15", "--set", "course"])
