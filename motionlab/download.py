"""Fetch CMU motion capture trials, as ASF/AMC files, from CMU's own site.

The CMU Graphics Lab Motion Capture Database serves every trial at
``<base>/subjects/<SS>/<SS>_<TT>.amc`` and each subject's skeleton at
``<base>/subjects/<SS>/<SS>.asf`` (``SS``: subject, ``TT``: trial, both at least two
digits). :func:`download_cmu` puts both side by side in one folder, which is the layout
:func:`motionlab.asfamc.load_locomotion` expects::

    paths = download_cmu(["16_15", (16, 35)])      # data/cache/cmu/16_15.amc, 16_35.amc, 16.asf
    positions, fps = asfamc.load_locomotion(paths[0])

or from a shell::

    python -m motionlab.download 16_15 16_35 --dest data/cache/cmu

Only the standard library talks to the network (``urllib``). What makes a download
complete and correct:

* **The reader is the validator.** Every file is parsed in full with
  :func:`motionlab.asfamc.read_asf` / :func:`~motionlab.asfamc.read_amc` (the AMC against
  its subject's ASF, which is fetched first), and every AMC frame must give the root and
  every bone with dofs, and the file must end with a line break. A file that does not
  pass is deleted and the error names the trial and the reason. This is also what catches
  a body cut short when the server announced no length: a transfer that breaks off
  mid-frame leaves an incomplete frame or line. (One cut exactly at a frame boundary
  would look like a shorter, complete trial; servers announce the length of these static
  files, and then the size is checked too.)
* **Safe resuming.** Each file is written to ``<name>.part``, with ``<name>.part.json``
  beside it recording where the bytes came from: the URL and the server's ``ETag``,
  ``Last-Modified`` and size. An interrupted download resumes with an HTTP ``Range``
  request (and ``If-Range``, so a file that changed on the server comes whole), and the
  answer must continue exactly at the part's end of the same file (``206`` with a matching
  ``Content-Range``, size and ``ETag``). A ``.part`` without that record, or recorded for
  another URL, is never spliced into: the download starts over.
* **A manifest.** ``manifest.json`` in the folder lists each file's URL, size, SHA-256
  and when it was recorded. On a later run, a file in the folder is checked against it; a
  file whose size or SHA-256 changed (damaged, or edited by hand) is reported with a
  :class:`DownloadWarning` and fetched again. A file in the folder but not in the manifest
  (copied in by hand, or left by an older version) is parsed as above: kept and added to
  the manifest if it passes, reported and fetched again if not.

Expected failures (no network, an HTTP error, an unknown trial, a file that is not a
valid ASF/AMC) raise :class:`DownloadError`, a ``ValueError``, with a message naming the
trial and the URL.

Licence: "The data used in this project was obtained from mocap.cs.cmu.edu. The database
was created with funding from NSF EIA-0196217." Free for research and commercial use; not
to be resold as a data set.
"""
from __future__ import annotations

import argparse
import json
import numbers
import os
import re
import sys
import urllib.error
import urllib.request
import warnings
from datetime import datetime, timezone
from http.client import HTTPException
from pathlib import Path
from typing import Callable, Iterable, Iterator
from urllib.parse import urlsplit

from tqdm.auto import tqdm

from . import asfamc, files
from .files import sha256_of

DEFAULT_BASE = "http://mocap.cs.cmu.edu"
DEFAULT_DEST = "data/cache/cmu"
MANIFEST = "manifest.json"
CHUNK_BYTES = 64 * 1024
USER_AGENT = "motionlab (course library; python urllib)"

DEFAULT_TRIALS = (
    # walks, on the flat and over obstacles
    "02_01", "03_01", "12_01", "16_15", "16_16", "16_21", "16_31", "16_32", "16_58", "29_01",
    "17_03",                                            # walk stealthily
    # walks that veer, turn 90 degrees, or slow down and stop
    "16_11", "16_13", "16_24", "16_26", "16_17", "16_19", "16_27", "16_30", "16_33",
    # runs and jogs
    "02_03", "09_01", "09_02", "09_03", "09_04", "09_05", "09_06", "09_08", "09_09", "09_11",
    "16_35", "16_36", "16_45", "16_46", "16_55", "127_03", "127_06",
    # runs that veer, turn, side-step, or stop
    "16_37", "16_39", "16_41", "16_43", "16_48", "16_49", "16_51", "16_53", "16_08", "16_57",
    "127_04", "127_05", "127_09", "127_11", "127_13", "127_15", "127_17",
    # forwards, backwards and sideways
    "09_12",
)
"""CMU locomotion trials: the 55 of the course's shared set (``../shared/mocap/cmu``).
``09_10`` is left out on purpose: its first AMC frames are all zeros, a flaw in the source."""


def trial_sets() -> dict[str, tuple[str, ...]]:
    """The named lists ``--set`` chooses from: ``"course"`` (:data:`DEFAULT_TRIALS`, 55
    curated trials) and ``"locomotion-full"`` (the 685 locomotion trials of CMU's index,
    :data:`motionlab.cmu_locomotion.LOCOMOTION_FULL`, with their descriptions there)."""
    from .cmu_locomotion import LOCOMOTION_FULL
    return {"course": DEFAULT_TRIALS, "locomotion-full": tuple(trial for trial, _ in LOCOMOTION_FULL)}


class DownloadError(ValueError):
    """A file could not be fetched: no network, an HTTP error, a broken-off transfer, or
    the server sent something that is not a valid ASF/AMC file."""


class DownloadWarning(UserWarning):
    """A file in the destination folder changed since it was recorded, or does not parse,
    and is fetched again."""


# --------------------------------------------------------------------------- names and URLs

_TRIAL = re.compile(r"^(\d{1,3})_(\d{1,3})$")


def trial_name(trial: str | tuple[int, int]) -> str:
    """CMU's name for a trial: ``"16_15"``, ``"2_1"`` or ``(2, 1)`` -> ``"16_15"``, ``"02_01"``."""
    if isinstance(trial, str) and _TRIAL.match(trial):
        subject, number = (int(x) for x in _TRIAL.match(trial).groups())
    elif (isinstance(trial, (tuple, list)) and len(trial) == 2
          and all(isinstance(x, numbers.Integral) and not isinstance(x, bool) for x in trial)):
        subject, number = int(trial[0]), int(trial[1])
    else:
        raise ValueError(f"trial: expected a name like '16_15' or a pair like (16, 15), got {trial!r}")
    if subject < 1 or number < 1:
        raise ValueError(f"trial: subject and trial numbers start at 1, got {trial!r}")
    return f"{subject:02d}_{number:02d}"


def trial_urls(trial: str | tuple[int, int], base_url: str = DEFAULT_BASE) -> tuple[str, str]:
    """The URLs of a trial's motion and of its subject's skeleton: ``(amc_url, asf_url)``."""
    name = trial_name(trial)
    subject = name.split("_")[0]
    folder = f"{base_url.rstrip('/')}/subjects/{subject}"
    return f"{folder}/{name}.amc", f"{folder}/{subject}.asf"


# --------------------------------------------------------------------------- content checks

def _first_line(head: bytes) -> str:
    """The first line of ``head`` that is neither blank nor a ``#`` comment."""
    for line in head.decode("latin-1").splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            return line.strip()
    return ""


def looks_like_amc(head: bytes) -> bool:
    """Whether a file starting with ``head`` is an AMC: a keyword such as ``:FULLY-SPECIFIED``
    or a frame number first. A quick first look; :func:`check_amc` is the real check."""
    line = _first_line(head)
    return line.upper().startswith((":FULLY-SPECIFIED", ":DEGREES", ":RADIANS")) or line.isdigit()


def looks_like_asf(head: bytes) -> bool:
    """Whether a file starting with ``head`` is an ASF: a section keyword (``:version``) first.
    A quick first look; :func:`check_asf` is the real check."""
    return _first_line(head).startswith(":")


def _describe(head: bytes) -> str:
    text = head.decode("latin-1", errors="replace").lstrip()
    if text[:100].lower().startswith(("<!doctype", "<html", "<?xml", "<head")):
        return "an HTML page (an error page?)"
    return f"something else, starting {text[:40]!r}"


def _check_last_line(path: Path) -> None:
    """CMU's files end with a line break; a transfer cut short mid-line does not."""
    with open(path, "rb") as f:
        f.seek(0, os.SEEK_END)
        if f.tell() == 0:
            raise ValueError(f"{path}: the file is empty")
        f.seek(-1, os.SEEK_END)
        if f.read(1) != b"\n":
            raise ValueError(f"{path}: the last line has no line break: the file was cut short")


def _read_strictly(read: Callable, *args) -> tuple[object, list[str]]:
    """Call a reader; returns what it read and the warnings it gave (a reader that copes
    with a flaw, say by dropping an incomplete last frame, warns; a download must have none)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = read(*args)
    complaints = []
    for warning in caught:
        if issubclass(warning.category, UserWarning):
            complaints.append(str(warning.message))
        else:                                             # not about the file: pass it on
            warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    return result, complaints


def check_asf(path: str | Path) -> asfamc.ASF:
    """Parse a skeleton file in full (:func:`motionlab.asfamc.read_asf`); returns it.
    Raises ``ValueError`` naming the file (and line) if it is not a complete ASF, or if
    the reader warned about it."""
    _check_last_line(Path(path))
    asf, complaints = _read_strictly(asfamc.read_asf, path)
    if complaints:
        raise ValueError(complaints[0])
    return asf


def check_amc(path: str | Path, asf: asfamc.ASF | str | Path) -> asfamc.AMC:
    """Parse a motion file in full against its skeleton (an :class:`~motionlab.asfamc.ASF`
    or the path of one); returns it.

    :func:`motionlab.asfamc.read_amc` checks every line and that frame numbers are
    contiguous; on top of that every frame must give the root and every bone with dofs
    (what ``:FULLY-SPECIFIED`` promises, and what a frame cut short lacks), and the reader
    must not have warned. Raises ``ValueError`` naming the file (and line) otherwise.
    """
    path = Path(path)
    if not isinstance(asf, asfamc.ASF):
        asf = check_asf(asf)
    _check_last_line(path)
    amc, complaints = _read_strictly(asfamc.read_amc, path, asf)
    _check_frames_complete(path, asf)
    if complaints:
        raise ValueError(complaints[0])
    return amc


def _bones_per_frame(path: Path) -> list[tuple[str, int, set[str]]]:
    """``(frame number, its line number, the bones it gives)`` for each frame of an AMC."""
    frames: list[tuple[str, int, set[str]]] = []
    with open(path, encoding="utf-8", errors="replace") as f:
        for n, line in enumerate(f, start=1):
            words = line.split()
            if not words or words[0].startswith(("#", ":")):
                continue
            if len(words) == 1 and words[0].isdigit():          # a new frame
                frames.append((words[0], n, set()))
            elif frames:
                frames[-1][2].add(words[0])
    return frames


def _check_frames_complete(path: Path, asf: asfamc.ASF) -> None:
    """Every frame of the AMC at ``path`` gives the root and every bone with dofs."""
    needed = {"root"} | {bone.name for bone in asf.bones if bone.dof}
    frames = _bones_per_frame(path)
    if not frames:
        raise ValueError(f"{path}: no frames")
    for number, line, given in frames:
        missing = sorted(needed - given)
        if missing:
            shown = ", ".join(missing[:3]) + (", ..." if len(missing) > 3 else "")
            raise ValueError(f"{path}:{line}: frame {number} lacks {len(missing)} of {len(needed)} "
                             f"bones ({shown}): an incomplete frame")


# --------------------------------------------------------------------------- the manifest

def read_manifest(folder: str | Path) -> dict[str, dict]:
    """``<folder>/manifest.json``: file name -> ``{"url", "size", "sha256", "recorded",
    "origin"}``; empty if there is none (or it is unreadable: then every file gets parsed)."""
    path = Path(folder) / MANIFEST
    if not path.is_file():
        return {}
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        warnings.warn(f"{path}: unreadable ({err}); the files are checked by parsing them",
                      DownloadWarning, stacklevel=2)
        return {}
    return manifest if isinstance(manifest, dict) else {}


def _record(path: Path, url: str, origin: str) -> None:
    """Add (or replace) ``path``'s entry in its folder's manifest."""
    manifest = read_manifest(path.parent)
    manifest[path.name] = {"url": url, "size": path.stat().st_size, "sha256": sha256_of(path),
                           "recorded": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                           "origin": origin}
    _write_json(path.parent / MANIFEST, manifest)


def _write_json(path: Path, value: dict) -> None:
    """Write ``value`` to ``path`` at once (through a temporary file), never half."""
    with files.replacing(path) as partial:
        partial.write_text(json.dumps(value, indent=1, sort_keys=True) + "\n", encoding="utf-8")


def _problem_with(target: Path, url: str, kind: str,
                  validate: Callable[[Path], object] | None) -> str | None:
    """Why the file already at ``target`` cannot be trusted, or ``None`` if it can.

    A file in the manifest must still have its recorded size and SHA-256. A file not in it
    must parse (``validate``); it is then added to the manifest.
    """
    entry = read_manifest(target.parent).get(target.name)
    if isinstance(entry, dict) and "sha256" in entry:
        size = target.stat().st_size
        if size != entry.get("size"):
            return (f"its size changed since it was recorded in {MANIFEST} "
                    f"({size} bytes, not {entry.get('size')})")
        if sha256_of(target) != entry["sha256"]:
            return f"its content changed since it was recorded in {MANIFEST} (another SHA-256)"
        return None
    try:
        if validate is not None:
            validate(target)
    except ValueError as err:
        return f"it is not in {MANIFEST} and is not a valid {kind} file ({err})"
    _record(target, url, "found in the folder, parsed")
    return None


# --------------------------------------------------------------------------- HTTP

def _offline(url: str, reason: object) -> DownloadError:
    host = urlsplit(url).netloc or url
    return DownloadError(
        f"could not reach {url} ({reason}). This machine seems to be offline, or {host} is "
        "unreachable. Check the network connection and try again; the site is sometimes down, "
        "so a mirror can be given with base_url= (--base-url on the command line).")


def _not_found(url: str, kind: str) -> DownloadError:
    hint = ("is that trial in the CMU database?" if kind == "AMC" else
            f"the trial needs this skeleton, {url.rsplit('/', 1)[-1]}; is the subject in the "
            "CMU database?")
    return DownloadError(f"{url}: not found on the server (HTTP 404); {hint}")


def _open(url: str, kind: str, timeout: float, headers: dict[str, str] | None = None):
    """Open ``url`` with extra request ``headers``. Returns the response, or ``None`` when
    the server answers that a requested range does not exist (HTTP 416)."""
    headers = {"User-Agent": USER_AGENT, **(headers or {})}
    try:
        return urllib.request.urlopen(urllib.request.Request(url, headers=headers), timeout=timeout)
    except urllib.error.HTTPError as err:
        if err.code == 416 and "Range" in headers:
            return None
        if err.code == 404:
            raise _not_found(url, kind) from None
        raise DownloadError(f"{url}: the server answered HTTP {err.code} {err.reason}") from None
    except (urllib.error.URLError, OSError, HTTPException) as err:
        raise _offline(url, getattr(err, "reason", err)) from None


def _total_size(response, offset: int) -> int | None:
    """The full file size the response announces (``Content-Range`` or ``Content-Length``)."""
    content_range = response.headers.get("Content-Range", "")
    if "/" in content_range and content_range.rsplit("/", 1)[1].strip().isdigit():
        return int(content_range.rsplit("/", 1)[1])
    length = response.headers.get("Content-Length")
    return offset + int(length) if length and length.strip().isdigit() else None


def _chunks(response, url: str) -> Iterator[bytes]:
    """The response body in chunks; a connection lost on the way is a :class:`DownloadError`."""
    while True:
        try:
            chunk = response.read(CHUNK_BYTES)
        except (OSError, HTTPException) as err:
            raise DownloadError(f"{url}: the transfer broke off ({err}); "
                                "run again to resume it") from None
        if not chunk:
            return
        yield chunk


# --------------------------------------------------------------------------- resuming a .part

def _part_files(target: Path) -> tuple[Path, Path]:
    """``<target>.part`` (the bytes so far) and ``<target>.part.json`` (where they came from)."""
    return target.with_name(target.name + ".part"), target.with_name(target.name + ".part.json")


def _discard(*paths: Path) -> None:
    for path in paths:
        path.unlink(missing_ok=True)


def _identity(url: str, response, offset: int) -> dict:
    """What identifies the file a response sends: URL, ``ETag``, ``Last-Modified``, size."""
    return {"url": url, "etag": response.headers.get("ETag"),
            "last_modified": response.headers.get("Last-Modified"),
            "size": _total_size(response, offset)}


def _read_identity(sidecar: Path) -> dict | None:
    try:
        identity = json.loads(sidecar.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return identity if isinstance(identity, dict) else None


def _strong_etag(identity: dict) -> str | None:
    etag = identity.get("etag")
    return etag if etag and not etag.startswith("W/") else None     # weak ETags cannot resume


def _can_resume(identity: dict | None, url: str) -> bool:
    """A part can be resumed only if it is recorded as coming from ``url``, with something
    to tell that the file on the server is still the same (``ETag``, date or size)."""
    return (identity is not None and identity.get("url") == url
            and bool(_strong_etag(identity) or identity.get("last_modified") or identity.get("size")))


def _range_headers(offset: int, identity: dict) -> dict[str, str]:
    """``Range`` from ``offset`` on, and ``If-Range``: "only if the file is still the one
    I have the start of; else send it whole"."""
    headers = {"Range": f"bytes={offset}-"}
    validator = _strong_etag(identity) or identity.get("last_modified")
    if validator:
        headers["If-Range"] = validator
    return headers


def _continues(response, offset: int, identity: dict) -> bool:
    """Whether a response is exactly the rest of the recorded file from ``offset`` on:
    ``206`` whose ``Content-Range`` starts at ``offset`` and runs to the end of a file of
    the recorded size, with the recorded ``ETag`` and ``Last-Modified`` (where given)."""
    match = re.fullmatch(r"bytes (\d+)-(\d+)/(\d+)", response.headers.get("Content-Range", "").strip())
    if response.status != 206 or not match:
        return False
    start, end, total = (int(x) for x in match.groups())
    same = [(identity.get(key), response.headers.get(header))
            for key, header in (("etag", "ETag"), ("last_modified", "Last-Modified"))]
    return (start == offset and end == total - 1 and identity.get("size") in (None, total)
            and all(ours is None or theirs is None or ours == theirs for ours, theirs in same))


def _open_rest(url: str, part: Path, sidecar: Path, kind: str, timeout: float):
    """Open ``url`` for what ``part`` still lacks: returns ``(offset, response)``, where
    ``offset`` is how many bytes of ``part`` to keep (0: start over, ``part`` is gone)."""
    identity = _read_identity(sidecar)
    offset = part.stat().st_size if part.is_file() else 0
    if offset and _can_resume(identity, url):
        response = _open(url, kind, timeout, _range_headers(offset, identity))
        if response is not None and _continues(response, offset, identity):
            return offset, response
        if response is not None and response.status == 200:      # the whole file after all
            _discard(part, sidecar)
            return 0, response
        if response is not None:
            response.close()
    _discard(part, sidecar)              # nothing to resume, or not safely: start over
    return 0, _open(url, kind, timeout)


def _download_part(url: str, part: Path, sidecar: Path, kind: str, timeout: float,
                   progress: bool) -> None:
    """Bring ``part`` up to the whole of ``url``, resuming it where that is safe (see
    :func:`_open_rest`); the received size must be the announced one."""
    offset, response = _open_rest(url, part, sidecar, kind, timeout)
    with response:
        if offset == 0:                                  # record where the bytes come from
            _write_json(sidecar, _identity(url, response, 0))
        total = _total_size(response, offset)
        with open(part, "ab" if offset else "wb") as out, \
                tqdm(total=total, initial=offset, unit="B", unit_scale=True, unit_divisor=1024,
                     desc=part.name.removesuffix(".part"), disable=not progress, leave=False) as bar:
            for chunk in _chunks(response, url):
                out.write(chunk)
                bar.update(len(chunk))
    size = part.stat().st_size
    if total is not None and size != total:
        raise DownloadError(f"{url}: received {size} of {total} bytes (the connection was "
                            "closed early); run again to resume")


# --------------------------------------------------------------------------- one file

def fetch(url: str, target: str | Path, looks_right: Callable[[bytes], bool], kind: str,
          timeout: float = 30.0, progress: bool = True,
          validate: Callable[[Path], object] | None = None) -> bool:
    """Make ``target`` a checked copy of ``url``; returns whether it downloaded.

    A file already at ``target`` is kept if it matches the folder's manifest (or, if not
    in it, passes ``validate``); otherwise a :class:`DownloadWarning` says why and it is
    fetched again. A download goes to ``<target>.part`` (resumed where safe), must have the
    announced size, start like the file should (``looks_right``) and pass ``validate``
    (a parse that raises ``ValueError``), else it is deleted. It is then renamed to
    ``target`` and recorded in the manifest. ``kind`` (``"ASF"``, ``"AMC"``) names it in
    messages. Raises :class:`DownloadError` (a ``ValueError``) naming ``url``.
    """
    target = Path(target)
    if target.is_file():
        problem = _problem_with(target, url, kind, validate)
        if problem is None:
            return False
        warnings.warn(f"{target}: {problem}; fetching it again", DownloadWarning, stacklevel=2)
        target.unlink()
    part, sidecar = _part_files(target)
    _download_part(url, part, sidecar, kind, timeout, progress)
    _check_download(url, part, sidecar, looks_right, kind, validate)
    os.replace(part, target)
    _discard(sidecar)
    _record(target, url, "downloaded")
    return True


def _check_download(url: str, part: Path, sidecar: Path, looks_right: Callable[[bytes], bool],
                    kind: str, validate: Callable[[Path], object] | None) -> None:
    """Delete a downloaded ``part`` (and its record) that is not a valid ``kind`` file."""
    with open(part, "rb") as f:
        head = f.read(4096)
    try:
        if not looks_right(head):
            raise DownloadError(f"{url}: expected a CMU {kind} file, the server sent {_describe(head)}")
        if validate is not None:
            try:
                validate(part)
            except ValueError as err:
                raise DownloadError(f"{url}: not a complete, valid {kind} file, so it was not "
                                    f"kept: {err}") from None
    except DownloadError:
        _discard(part, sidecar)
        raise


# --------------------------------------------------------------------------- many trials

def download_cmu(trials: Iterable[str | tuple[int, int]] | None = None,
                 dest: str | Path = DEFAULT_DEST, base_url: str = DEFAULT_BASE,
                 progress: bool = True, timeout: float = 30.0) -> list[Path]:
    """Fetch CMU trials and their subjects' skeletons into ``dest``; returns the AMC paths.

    Args:
        trials: names like ``"16_15"`` or pairs like ``(16, 15)``; default
            :data:`DEFAULT_TRIALS`.
        dest: the folder, created if needed; it gets ``<SS>_<TT>.amc``, ``<SS>.asf`` and
            ``manifest.json`` (each file's URL, size and SHA-256).
        base_url: the site (or a mirror with the same ``/subjects/<SS>/`` layout).
        progress: show a progress bar (bytes) per file.
        timeout: seconds to wait for the server before giving up.

    Each trial's skeleton is fetched first, then the trial, and each is parsed in full
    before it is kept (see the module's docstring). Files already in ``dest`` are checked
    against the manifest, not fetched again; one that changed is reported (a
    :class:`DownloadWarning`) and fetched again. A ``.part`` left by an interrupted run is
    resumed when that is safe. Raises ``ValueError`` for a bad trial name, and
    :class:`DownloadError` (a ``ValueError``) naming the trial and the URL when the site
    cannot be reached, answers with an error or sends something that is not a valid
    ASF/AMC file.
    """
    names = [trial_name(t) for t in (DEFAULT_TRIALS if trials is None else trials)]
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in dict.fromkeys(names):                     # each trial once, in order
        try:
            paths.append(_fetch_trial(name, dest, base_url, progress, timeout))
        except DownloadError as err:
            raise DownloadError(f"trial {name}: {err}") from None
    return paths


def _fetch_trial(name: str, dest: Path, base_url: str, progress: bool, timeout: float) -> Path:
    """One trial: its subject's skeleton first (the AMC is parsed against it), then its motion."""
    amc_url, asf_url = trial_urls(name, base_url)
    asf_path, amc_path = dest / asf_url.rsplit("/", 1)[1], dest / f"{name}.amc"
    fetch(asf_url, asf_path, looks_like_asf, "ASF", timeout, progress, validate=check_asf)
    fetch(amc_url, amc_path, looks_like_amc, "AMC", timeout, progress,
          validate=lambda path: check_amc(path, asf_path))
    return amc_path


def _print_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"warning: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m motionlab.download",
        description="Download CMU motion capture trials (ASF/AMC) from mocap.cs.cmu.edu.")
    parser.add_argument("trials", nargs="*", metavar="TRIAL", help="trials like 16_15 (default: "
                        f"the {len(DEFAULT_TRIALS)} locomotion trials of the course)")
    parser.add_argument("--set", dest="trial_set", choices=sorted(trial_sets()), default=None,
                        help="a named list instead: 'course' (the default 55) or 'locomotion-full' "
                             "(685 locomotion trials of CMU's index, listed in motionlab/cmu_locomotion.tsv)")
    parser.add_argument("--dest", default=DEFAULT_DEST,
                        help=f"folder for the files (default: {DEFAULT_DEST})")
    parser.add_argument("--base-url", default=DEFAULT_BASE,
                        help=f"the site or a mirror (default: {DEFAULT_BASE})")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    if args.trial_set and args.trials:
        parser.error("give trials or --set, not both")
    trials = trial_sets()[args.trial_set] if args.trial_set else args.trials or None
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _print_warning          # "warning: ...", no source line
            paths = download_cmu(trials, args.dest, args.base_url, progress=not args.quiet)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    folder = Path(args.dest).resolve()
    print(f"{len(paths)} trial{'' if len(paths) == 1 else 's'} (.amc, with the subjects' .asf "
          f"skeletons) in {folder}")
    print("load one with: motionlab.asfamc.load_locomotion(path)  # (frames, 21, 3) metres, 120 fps")
    return 0


if __name__ == "__main__":
    sys.exit(main())
