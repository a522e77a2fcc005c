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

Only the standard library talks to the network (``urllib``). Each file is written to
``<name>.part`` and renamed when complete, so an interrupted download resumes where it
stopped (an HTTP ``Range`` request) and a complete file is never fetched again. A file is
accepted only if it has the announced size and looks like an ASF or AMC file (not, say, an
HTML error page).

Licence: "The data used in this project was obtained from mocap.cs.cmu.edu. The database
was created with funding from NSF EIA-0196217." Free for research and commercial use; not
to be resold as a data set.
"""
from __future__ import annotations

import argparse
import numbers
import os
import re
import sys
import urllib.error
import urllib.request
from http.client import HTTPException
from pathlib import Path
from typing import Callable, Iterable
from urllib.parse import urlsplit

from tqdm.auto import tqdm

DEFAULT_BASE = "http://mocap.cs.cmu.edu"
DEFAULT_DEST = "data/cache/cmu"
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


class DownloadError(ValueError):
    """A file could not be fetched: no network, an HTTP error, or a broken-off transfer."""


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
    or a frame number first."""
    line = _first_line(head)
    return line.upper().startswith((":FULLY-SPECIFIED", ":DEGREES", ":RADIANS")) or line.isdigit()


def looks_like_asf(head: bytes) -> bool:
    """Whether a file starting with ``head`` is an ASF: a section keyword (``:version``) first."""
    return _first_line(head).startswith(":")


def _describe(head: bytes) -> str:
    text = head.decode("latin-1", errors="replace").lstrip()
    if text[:100].lower().startswith(("<!doctype", "<html", "<?xml", "<head")):
        return "an HTML page (an error page?)"
    return f"something else, starting {text[:40]!r}"


# --------------------------------------------------------------------------- one file

def _offline(url: str, reason: object) -> DownloadError:
    host = urlsplit(url).netloc or url
    return DownloadError(
        f"could not reach {url} ({reason}). This machine seems to be offline, or {host} is "
        "unreachable. Check the network connection and try again; the site is sometimes down, "
        "so a mirror can be given with base_url= (--base-url on the command line).")


def _open(url: str, offset: int, timeout: float):
    """Open ``url``, asking for the bytes from ``offset`` on when it is not 0.

    Returns the response, or ``None`` when the server says that range does not exist
    (HTTP 416: the part on disk is not a prefix of the file).
    """
    headers = {"User-Agent": USER_AGENT}
    if offset:
        headers["Range"] = f"bytes={offset}-"
    try:
        return urllib.request.urlopen(urllib.request.Request(url, headers=headers), timeout=timeout)
    except urllib.error.HTTPError as err:
        if err.code == 416 and offset:
            return None
        if err.code == 404:
            raise DownloadError(f"{url}: not found on the server (HTTP 404); "
                                "is that trial in the CMU database?") from None
        raise DownloadError(f"{url}: the server answered HTTP {err.code} {err.reason}") from None
    except (urllib.error.URLError, TimeoutError, ConnectionError, HTTPException) as err:
        raise _offline(url, getattr(err, "reason", err)) from None


def _total_size(response, offset: int) -> int | None:
    """The full file size the response announces (``Content-Range`` or ``Content-Length``)."""
    content_range = response.headers.get("Content-Range", "")
    if "/" in content_range and content_range.rsplit("/", 1)[1].strip().isdigit():
        return int(content_range.rsplit("/", 1)[1])
    length = response.headers.get("Content-Length")
    return offset + int(length) if length and length.strip().isdigit() else None


def _download_part(url: str, part: Path, timeout: float, progress: bool) -> None:
    """Bring ``part`` up to the whole of ``url``: resume it with a ``Range`` request if it
    exists, start over if the server cannot or will not resume; check the announced size."""
    offset = part.stat().st_size if part.is_file() else 0
    response = _open(url, offset, timeout)
    if response is None:                                  # the part is not a prefix: start over
        part.unlink()
        offset, response = 0, _open(url, 0, timeout)
    with response:
        if offset and response.status != 206:
            offset = 0                                     # Range ignored, whole file: restart
        elif offset and not response.headers.get("Content-Range", "").startswith(f"bytes {offset}-"):
            part.unlink()
            raise DownloadError(f"{url}: the server sent another range than bytes {offset}- "
                                f"({response.headers.get('Content-Range')}); run again to start over")
        total = _total_size(response, offset)
        with open(part, "ab" if offset else "wb") as out, \
                tqdm(total=total, initial=offset, unit="B", unit_scale=True, unit_divisor=1024,
                     desc=part.name.removesuffix(".part"), disable=not progress, leave=False) as bar:
            try:
                while chunk := response.read(CHUNK_BYTES):
                    out.write(chunk)
                    bar.update(len(chunk))
            except (TimeoutError, ConnectionError, HTTPException) as err:
                raise DownloadError(f"{url}: the transfer broke off ({err}); run again to "
                                    "resume it") from None
    size = part.stat().st_size
    if total is not None and size != total:
        raise DownloadError(f"{url}: received {size} of {total} bytes; run again to resume")


def fetch(url: str, target: str | Path, looks_right: Callable[[bytes], bool], kind: str,
          timeout: float = 30.0, progress: bool = True) -> bool:
    """Download ``url`` to ``target`` unless ``target`` exists; returns whether it downloaded.

    Writes ``<target>.part`` first and resumes it with a ``Range`` request (a server that
    ignores ``Range`` sends the whole file, which then replaces the part). The file must
    have the size the server announced and its start must pass ``looks_right`` (else the
    part is deleted); ``kind`` names it in messages. Raises :class:`DownloadError` (a
    ``ValueError``) naming ``url``.
    """
    target = Path(target)
    if target.is_file():
        return False
    part = target.with_name(target.name + ".part")
    _download_part(url, part, timeout, progress)
    with open(part, "rb") as f:
        head = f.read(4096)
    if not looks_right(head):
        part.unlink()
        raise DownloadError(f"{url}: expected a CMU {kind} file, the server sent {_describe(head)}")
    os.replace(part, target)
    return True


# --------------------------------------------------------------------------- many trials

def download_cmu(trials: Iterable[str | tuple[int, int]] | None = None,
                 dest: str | Path = DEFAULT_DEST, base_url: str = DEFAULT_BASE,
                 progress: bool = True, timeout: float = 30.0) -> list[Path]:
    """Fetch CMU trials and their subjects' skeletons into ``dest``; returns the AMC paths.

    Args:
        trials: names like ``"16_15"`` or pairs like ``(16, 15)``; default
            :data:`DEFAULT_TRIALS`.
        dest: the folder, created if needed; it gets ``<SS>_<TT>.amc`` and ``<SS>.asf``.
        base_url: the site (or a mirror with the same ``/subjects/<SS>/`` layout).
        progress: show a progress bar (bytes) per file.
        timeout: seconds to wait for the server before giving up.

    Files already in ``dest`` are not fetched again; a ``.part`` left by an interrupted run
    is resumed. Raises ``ValueError`` for a bad trial name, and :class:`DownloadError` (a
    ``ValueError``) naming the URL when the site cannot be reached, answers with an error
    or sends something that is not an ASF/AMC file.
    """
    names = [trial_name(t) for t in (DEFAULT_TRIALS if trials is None else trials)]
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in dict.fromkeys(names):                     # each trial once, in order
        amc_url, asf_url = trial_urls(name, base_url)
        fetch(asf_url, dest / asf_url.rsplit("/", 1)[1], looks_like_asf, "ASF", timeout, progress)
        fetch(amc_url, dest / f"{name}.amc", looks_like_amc, "AMC", timeout, progress)
        paths.append(dest / f"{name}.amc")
    return paths


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m motionlab.download",
        description="Download CMU motion capture trials (ASF/AMC) from mocap.cs.cmu.edu.")
    parser.add_argument("trials", nargs="*", metavar="TRIAL", help="trials like 16_15 (default: "
                        f"the {len(DEFAULT_TRIALS)} locomotion trials of the course)")
    parser.add_argument("--dest", default=DEFAULT_DEST,
                        help=f"folder for the files (default: {DEFAULT_DEST})")
    parser.add_argument("--base-url", default=DEFAULT_BASE,
                        help=f"the site or a mirror (default: {DEFAULT_BASE})")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    try:
        paths = download_cmu(args.trials or None, args.dest, args.base_url, progress=not args.quiet)
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
