"""One file over HTTP, resumed where that is safe: :func:`fetch`.

A download goes to ``<name>.part``, with ``<name>.part.json`` beside it recording where the
bytes came from (the URL, the server's ``ETag``, ``Last-Modified`` and size). An interrupted
download resumes with an HTTP ``Range`` request (and ``If-Range``), and the answer must
continue exactly at the part's end of the same file; otherwise it starts over. The finished
part must have the announced size and pass its checks (:mod:`motionlab.download_checks`)
before it is renamed and recorded in the manifest. Only the standard library talks to the
network (``urllib``); failures are :class:`~motionlab.download_checks.DownloadError` s naming
the URL.
"""
from __future__ import annotations

import json
import os
import re
import urllib.error
import urllib.request
import warnings
from http.client import HTTPException
from pathlib import Path
from typing import Callable, Iterator
from urllib.parse import urlsplit

from tqdm.auto import tqdm

from .download_checks import DownloadError, DownloadWarning, _describe, _problem_with, _record, _write_json

CHUNK_BYTES = 64 * 1024
USER_AGENT = "motionlab (course library; python urllib)"


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
