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

The checks and the manifest are :mod:`motionlab.download_checks`, one file's download and
its resuming :mod:`motionlab.download_http`; their names are importable from here too. This
module names the trials and fetches many (:func:`download_cmu`, the command line).

Licence: "The data used in this project was obtained from mocap.cs.cmu.edu. The database
was created with funding from NSF EIA-0196217." Free for research and commercial use; not
to be resold as a data set.
"""
from __future__ import annotations

import argparse
import numbers
import re
import sys
import warnings
from pathlib import Path
from typing import Iterable

from .download_checks import (MANIFEST, DownloadError, DownloadWarning, check_amc, check_asf, looks_like_amc,
                              looks_like_asf, read_manifest)
from .download_http import CHUNK_BYTES, USER_AGENT, fetch

__all__ = ["CHUNK_BYTES", "DEFAULT_BASE", "DEFAULT_DEST", "DEFAULT_TRIALS", "MANIFEST", "USER_AGENT",
           "DownloadError", "DownloadWarning", "check_amc", "check_asf", "download_cmu", "fetch",
           "looks_like_amc", "looks_like_asf", "main", "read_manifest", "trial_name", "trial_sets",
           "trial_urls"]

DEFAULT_BASE = "http://mocap.cs.cmu.edu"
DEFAULT_DEST = "data/cache/cmu"

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
