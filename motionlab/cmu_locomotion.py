"""Locomotion trials of the CMU Graphics Lab Motion Capture Database (mocap.cs.cmu.edu),
with CMU's own description of each: ``python -m motionlab.download --set locomotion-full``.

Source of the index text
------------------------
CMU's trial descriptions were copied from the stored public copy of the
cgspeed / B. Hahne compilation of CMU's motion index:

    repository: una-dinosauria/cmu-mocap
    path:       cmu-mocap-index-text.txt
    commit:     34e1472e5b8c234d40a62bb9cd969b5910fa1803
    header:     "Carnegie-Mellon Graphics Lab Motion Capture Database /
                 full file listing with descriptions, word processor format /
                 v1.00 last update July 20, 2008 / Compiled from the individual
                 CMU index files by B. Hahne"  (http://mocap.cs.cmu.edu)

That file lists 2435 trials (109 subjects, 01..144).  Each line of
``cmu_locomotion.tsv`` (beside this file) is a trial and its description, with the trial name and the description exactly as in
that file (internal spacing kept, e.g. "RunningNoBall     CleanedGRS").

Selection rule
--------------
A trial is kept when its CMU description says the subject moves across the
floor on foot -- walk / run / jog / march / limp / hobble / stride / sneak /
creep / pacing / navigate / sidestep / turn in place, walking backwards,
sideways, in curves, figure eights, with 90-degree turns, starting and
stopping -- and the description does not name a different main activity.
Dropped: dance, ball sports (all of subjects 78 and 102 except "RunningNoBall"),
jumping/hopping/leaping, climbing, stairs, ledges, stepping over things or
stepping up/down, ducking/diving/rolling, sitting, stretching, boxing/attacks,
carrying or picking up objects, pushing/pulling/dragging heavy objects,
two-person contact (shake hands, link arms, hold hands, catch, high-five,
lead by the arm), multi-activity "vignettes", subject 133 ("Baby Styled
Walk") and 142_01 "Childish" (child animation), and trials whose description
is "Unknown", "clean", "Story", a bare number or otherwise does not say the
motion is locomotion.  Stylised adult walks are kept (e.g. 17_*, 91_*/105_*,
132_*, 136_*, the "... Walk" trials of 137, "Marching" of 138).  Subject 142's
heading is "Stylized Walks", so its mood-named trials (e.g. "Clumsy", "Sad")
are kept, except "Childish" and the two "Singing in the rain jump" trials.
When in doubt a trial was left out.
"""

from __future__ import annotations

import re
from pathlib import Path

TRIALS_FILE = Path(__file__).with_name("cmu_locomotion.tsv")
"""The list: a header line ``trial<TAB>description``, then one trial per line."""

_TRIAL = re.compile(r"\d{2,3}_\d{2}")
MAX_LINES = 10_000                 # CMU's whole index has 2435 trials


def read_trials(path: str | Path = TRIALS_FILE) -> tuple[tuple[str, str], ...]:
    """``((trial, description), ...)`` from a list written like :data:`TRIALS_FILE`; a
    malformed line raises ``ValueError`` naming the file and the line."""
    path = Path(path)
    lines = path.read_text(encoding="utf-8").splitlines()
    if not lines or lines[0] != "trial\tdescription":
        raise ValueError(f"{path}, line 1: expected the header 'trial<TAB>description'")
    if len(lines) > MAX_LINES:
        raise ValueError(f"{path}: {len(lines)} lines, more than the {MAX_LINES} a trial list may have")
    rows, seen = [], set()
    for number, line in enumerate(lines[1:], start=2):
        trial, tab, description = line.partition("\t")
        if not tab or not _TRIAL.fullmatch(trial) or not description.strip() or "\t" in description:
            raise ValueError(f"{path}, line {number}: expected 'SUBJECT_TRIAL<TAB>description' "
                             f"(e.g. '02_01<TAB>walk'), got {line!r}")
        if trial in seen:
            raise ValueError(f"{path}, line {number}: trial {trial} is listed twice")
        seen.add(trial)
        rows.append((trial, description))
    return tuple(rows)


LOCOMOTION_FULL = read_trials()
"""The 685 locomotion trials and CMU's description of each, as ``(trial, description)``."""
