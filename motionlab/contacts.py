"""Feet that stay planted: foot contacts, foot locking with two-bone IK, and bones put back
to their lengths. What turns a model's samples into a character.

Why generated feet slide. In the root-local representation (``representation``) the body
moves by the control, and a planted foot must sweep backwards in the root frame by exactly
the control's displacement every frame to stay still in the world. A model predicts that
sweep with some error (sampling noise from frame to frame, a stride on average a little
short), and every centimetre of error is a centimetre of sliding over the floor. None of
the four papers fixes this; every system that ships characters does, the same way (PFNN,
Holden et al. 2017; Learned Motion Matching, Holden et al. 2020; GANimator, Li et al. 2022):
label the contacts, then keep a foot in contact where it landed and let the leg reach it.

Three functions, one per step, on world positions ``(..., frames, 21, 3)`` in metres:

* :func:`detect`: contact labels ``(..., frames, 4)`` for the ankles and toes
  (:data:`FEET` order), from each joint's height above its planted height and its
  horizontal speed, with hysteresis and a short majority filter;
* :func:`lock_feet` (:func:`lock` also returns what it did): while a foot is in contact it
  stays where it landed, on the floor; the leg reaches it by analytic two-bone IK (hip
  fixed, bone lengths the motion's own, knee in the plane it bent in); the lock lets go
  when the contact ends or the foot runs out of the leg's reach, and both transitions blend
  over :data:`BLEND_S` (no pops). Knowing the whole clip, it also slows a low foot into
  the spot where it will land (:func:`approach_shift`). Nothing above the hips moves;
* :func:`fit_bones`: every bone back to one length (the motion's median or the data's),
  each bone's direction kept.

:class:`FootLock` is the same lock one frame at a time, with no look-ahead: what a
real-time stream (``MoGlowStream``) can use. :func:`lock` is that class run over a clip.

The labels come from :mod:`motionlab.contact_detection` (:func:`detect`, its thresholds,
:func:`planted_heights`, :func:`planted_speed`, :func:`horizontal_speed`); their names are
importable from here too.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import checks
from .contact_detection import (BODY_FRACTION, CLEAN_S, CONTACT_HEIGHT_M, CONTACT_SPEED_MS, RELEASE,
                                SPEED_WINDOW_S, _contact_array, _per_foot_joint, _positions, detect,
                                horizontal_speed, planted_heights, planted_speed)
from .filters import smoothstep
from .representation import along_path, to_positions
from .skeleton import FEET, LOCOMOTION, Skeleton

__all__ = ["APPROACH_HEIGHT", "APPROACH_S", "BLEND_S", "BODY_FRACTION", "CLEAN_S", "CONTACT_HEIGHT_M",
           "CONTACT_SPEED_MS", "FEET", "FOLLOW", "LEGS", "LOW_FADE", "PIVOT_BEND", "PLANTED_HEIGHT_M", "REACH_SLACK_M",
           "RELEASE", "RELEASE_S", "SPEED_WINDOW_S", "FootLock", "Finished", "Locked", "approach_shift", "body_lengths",
           "contact_labels", "contact_velocity_loss", "detect", "finish", "fit_bones", "foot_velocity",
           "horizontal_speed", "lock", "lock_feet", "planted_heights", "planted_speed", "two_bone_ik"]

# ----------------------------------------------------------------------------------------
# Thresholds of the lock (measured on the built-in data; see notebook 01, section 5)
# ----------------------------------------------------------------------------------------

BLEND_S = 0.15
"""How long the lock takes to draw a landing foot onto the floor, seconds."""

APPROACH_S = 0.15
"""How long before a contact begins the offline lock slows a low foot into its landing
spot, seconds (:func:`approach_shift`). A generated foot often comes down still sliding
forward and is held only when it has slowed; the data's feet slow in the air."""

LANDING_GUESS = 0.3
"""The causal lock's landing step (:class:`FootLock`, which cannot see where a foot lands):
a low foot coming down is drawn ahead along its horizontal velocity by this fraction of the
distance that velocity would carry it before its height reaches the floor at its present
rate of descent, over the last :data:`APPROACH_S` before it would land, and from no higher
than :data:`APPROACH_HEIGHT` times its contact height, as the offline landing step. Measured
on ``benchmarks/feet.py``'s samples at 0, 0.15, 0.3, 0.5 and 1: 0.3 lowers the streamed
models' skating most with the feet's acceleration within the course's bound (0.5 and 1
overshoot, and the feet jump back as they land)."""

APPROACH_HEIGHT = 2.0
"""... and from how high: a foot joint is drawn towards its landing spot fully on the floor,
not at all from this many times its contact height (:data:`CONTACT_HEIGHT_M`) above it. Up
to 1.5 times, a foot that comes down steeply still lands sliding; from 3 times or with no
limit the feet's acceleration rises to 1.5-1.6 times the motion's."""

RELEASE_S = 0.25
"""How long a foot that lets go takes to rejoin the motion, seconds: long enough that most
of the catching up happens in the air, where it is not sliding."""

PLANTED_HEIGHT_M = (0.081, 0.034, 0.081, 0.034)
"""Planted heights of the built-in bodies' ankles and toes, metres (the 5th percentile of
their height, ``metrics.foot_rest_heights``): the floor the causal lock uses when it is
given none and cannot look at a whole clip."""

FOLLOW = 0.5
"""Per frame, how much of its own offset a foot joint out of contact keeps while the other
joint of its foot is held (the rest is the held joint's): the heel of a planted toe goes
with it, within a few frames."""

LOW_FADE = 0.25
"""While a foot that let go is still within its contact height of the floor, its fade runs
at this fraction of its speed: the catching up happens in the air, not along the floor."""

PIVOT_BEND = 0.01
"""A foot that pivots on its toe leaves its leg this fraction short of straight, so that
the knee keeps a direction to bend in."""

REACH_SLACK_M = 0.02
"""How far a locked ankle may fall short of its target, the leg stretched, or a held toe lie
beyond a pivoting foot's reach, before the lock lets go (metres): short of full reach the
foot slides by at most this much."""

LEGS = tuple(tuple(LOCOMOTION.index(side + name) for name in ("UpLeg", "Leg", "Foot", "ToeBase"))
             for side in ("Left", "Right"))
"""Hip, knee, ankle and toe of the left and of the right leg (locomotion skeleton)."""

assert tuple(j for leg in LEGS for j in leg[2:]) == FEET


# ----------------------------------------------------------------------------------------
# 2. Two-bone IK and the foot lock
# ----------------------------------------------------------------------------------------

def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(norm, 1e-12), norm[..., 0]


def two_bone_ik(hip, knee, ankle, target, pole_hint=None, reach_slack_m: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Analytic two-bone IK: the knee and ankle that put the ankle on ``target`` with the
    hip fixed, the thigh and shin keeping the lengths they have in ``hip, knee, ankle``,
    and the knee in the plane it bent in. All ``(..., 3)``; returns ``(knee, ankle,
    reached)`` where ``reached`` ``(...)`` is False where the target was more than
    ``reach_slack_m`` out of reach (the leg then points straight at it, fully stretched).

    The law of cosines gives the angle at the hip, ``cos a = (l1² + d² − l2²) / (2 l1 d)``
    for the hip-target distance ``d``; the knee lies at ``l1`` from the hip, at angle ``a``
    from the hip-target line, towards where the knee pointed (``knee`` minus its projection
    on that line; ``pole_hint`` where the leg was straight, e.g. the foot's direction).
    """
    thigh = np.linalg.norm(knee - hip, axis=-1)
    shin = np.linalg.norm(ankle - knee, axis=-1)
    direction, distance = _unit(target - hip)
    lo, hi = np.abs(thigh - shin) + 1e-6, (thigh + shin) * (1 - 1e-6)
    reached = (distance >= lo - reach_slack_m) & (distance <= hi + reach_slack_m)
    d = np.clip(distance, lo, hi)
    pole = knee - hip
    pole = pole - (pole * direction).sum(-1, keepdims=True) * direction
    if pole_hint is not None:
        hint = pole_hint - (pole_hint * direction).sum(-1, keepdims=True) * direction
        straight = np.linalg.norm(pole, axis=-1, keepdims=True) < 1e-4
        pole = np.where(straight, hint, pole)
    pole, _ = _unit(pole)
    cos_a = np.clip((thigh ** 2 + d ** 2 - shin ** 2) / (2 * thigh * d), -1.0, 1.0)[..., None]
    new_knee = hip + thigh[..., None] * (cos_a * direction + np.sqrt(1 - cos_a ** 2) * pole)
    return new_knee, hip + d[..., None] * direction, reached


def _pivot(hip, toe, reach, foot, near) -> tuple[np.ndarray, np.ndarray]:
    """Where an ankle can be, ``reach`` from the ``hip`` and ``foot`` from the ``toe``
    (the circle where two spheres meet), on the side of ``near``: ``(n, 3)``, and whether
    the spheres meet, within :data:`REACH_SLACK_M` ``(n,)``. Where they do not, the point
    on the hip-toe line at ``reach``: the toe is out of even a pivoting foot's reach."""
    u, d = _unit(toe - hip)
    x = np.clip((d ** 2 + reach ** 2 - foot ** 2) / (2 * np.maximum(d, 1e-9)), -reach, reach)
    r = np.sqrt(np.maximum(reach ** 2 - x ** 2, 0.0))
    w = near - hip
    w, _ = _unit(w - (w * u).sum(-1, keepdims=True) * u)
    return hip + x[:, None] * u + r[:, None] * w, d <= reach + foot + REACH_SLACK_M


class FootLock:
    """The foot lock, causal: :meth:`step` takes one frame (of ``batch`` characters) and
    returns it with the feet locked, using nothing from later frames.

    * **Holding.** Each foot joint (ankle, toe) carries a horizontal offset ``O`` added to
      its position. While a joint is in contact, ``O`` cancels its horizontal motion, so it
      stays where it landed; the other joint of a held foot follows it (:data:`FOLLOW`),
      so the foot moves as one. The foot's lowest joint in contact is drawn onto its
      planted height over :data:`BLEND_S` (less as it rises towards the release height).
    * **The leg.** The ankle reaches its target by :func:`two_bone_ik` (hip fixed, the
      leg's own bone lengths, knee in its plane); a held toe fixes the ankle at a foot's
      length from it; beyond the leg's reach the heel rises and the foot pivots on its toe
      (:func:`_pivot`), as a walker's does at toe-off. The foot bone then points from the
      new ankle at the toe's target, its length kept. Only the knee, ankle and toe move.
    * **Letting go.** When the contact ends, or the leg cannot reach the held foot even
      pivoting on its toe (the toe more than the leg's reach plus the foot's length, plus
      :data:`REACH_SLACK_M`, from the hip: the body has moved on without stepping), ``O``
      fades to zero over :data:`RELEASE_S` (slowed by :data:`LOW_FADE` while the
      foot is still near the floor) and the height correction over :data:`BLEND_S`:
      smoothsteps, so the foot rejoins the motion without a jump (a heel the pivot raised
      drops back at once). A foot let go for reach stays free until its contact ends.

    * **Landing.** Where the offline lock knows where a foot lands (:func:`approach_shift`),
      this one guesses: a low foot coming down is drawn ahead along its own horizontal
      velocity, by ``landing`` (:data:`LANDING_GUESS`; 0: off) times the distance that
      velocity would carry it before it reaches the floor at its present rate of descent.

    Contacts: pass them to :meth:`step`, or let the lock detect them causally (height
    above the planted height and backward-difference speed, with hysteresis; no filter,
    which would need later frames).
    """

    def __init__(self, fps: float, batch: int = 1, planted_height_m=PLANTED_HEIGHT_M,
                 height_m=CONTACT_HEIGHT_M, speed_ms: float = CONTACT_SPEED_MS,
                 body_fraction: float = BODY_FRACTION, blend_s: float = BLEND_S, release_s: float = RELEASE_S,
                 landing: float = LANDING_GUESS):
        self.fps = checks.rate(fps, "fps")
        self.batch = checks.whole(batch, "batch")
        self.floor = _per_foot_joint(planted_height_m, "planted_height_m", positive=False)
        self.height_m = _per_foot_joint(height_m, "height_m")
        self.speed_ms = checks.positive(speed_ms, "speed_ms")
        self.body_fraction = checks.non_negative(body_fraction, "body_fraction", 10.0)
        self.blend = max(1.0, checks.non_negative(blend_s, "blend_s", checks.MAX_SECONDS) * self.fps)
        self.release = max(1.0, checks.non_negative(release_s, "release_s", checks.MAX_SECONDS) * self.fps)
        self.landing = checks.non_negative(landing, "landing", 1.0)
        self.reset()

    def reset(self) -> None:
        """Forget every foot's state (a new clip starts)."""
        b = self.batch
        self.previous = None                               # last raw frame (b, 21, 3)
        self.contact = np.zeros((b, 4), dtype=bool)        # contact per foot joint, last frame
        self.locked = np.zeros((b, 2), dtype=bool)         # per foot: the lock holds it
        self.blocked = np.zeros((b, 2), dtype=bool)        # let go for reach: wait for the contact to end
        self.offset = np.zeros((b, 4, 2))                  # per foot joint: horizontal offset O (x, z), metres
        self.lift = np.zeros((b, 2))                       # per foot: height correction, metres
        self.held = np.zeros((b, 2))                       # per foot: frames held so far
        self.age = np.full((b, 2), np.inf)                 # per foot: how far its offset has faded, frames
        self.lift_age = np.full((b, 2), np.inf)            # per foot: frames since it let go (inf: long ago)
        self.let_go = np.zeros((b, 4, 2))                  # per foot joint: its offset when the foot let go
        self.lift_from = np.zeros((b, 2))                  # per foot: its lift when it let go
        self.frames = 0
        self.locked_frames = 0                             # foot-frames spent locked
        self.reach_releases = 0                            # locks let go because the leg could not reach
        self.pivot_frames = 0                              # foot-frames held by pivoting on the toe

    def _detect(self, frame: np.ndarray) -> np.ndarray:
        feet = frame[:, FEET]
        above = feet[..., 1] - self.floor
        if self.previous is None:
            speed, limit = np.zeros(above.shape), self.speed_ms
        else:
            step = frame[:, [0, *FEET]][..., [0, 2]] - self.previous[:, [0, *FEET]][..., [0, 2]]
            speed = np.linalg.norm(step, axis=-1) * self.fps                 # (b, hips + 4 feet)
            speed, limit = speed[:, 1:], np.maximum(self.speed_ms, self.body_fraction * speed[:, :1])
        enter = (above < self.height_m) & (speed < limit)
        stay = (above < RELEASE * self.height_m) & (speed < RELEASE * limit)
        return enter | (self.contact & stay)

    def _contacts(self, contacts, single: bool, name: str = "contacts") -> np.ndarray:
        contact = np.asarray(contacts)
        return _contact_array(contact[None] if single and contact.ndim == 1 else contact, (self.batch, 4), name)

    def step(self, frame, contacts=None, approach=None, drawn=None) -> np.ndarray:
        """One frame ``(batch, 21, 3)`` (or ``(21, 3)`` when ``batch`` is 1) in, the same
        with the feet locked out. ``contacts`` ``(batch, 4)`` booleans (:data:`FEET` order)
        or None to detect them. ``drawn``: with ``contacts`` None, the model's own contacts
        for this frame, ``(batch, 4)`` booleans (a contact head's, ``MoGlowStream.contacts``):
        a foot joint is then in contact where the detector *or* the model says it is, so that
        a foot the model planted is held from the frame it lands. ``approach`` ``(batch, 4,
        2)`` or None: a horizontal shift (x, z) for the joints of feet the lock does not hold
        (:func:`approach_shift`, which needs later frames: the offline lock's); None: the
        lock's own guess (:meth:`landing_guess`)."""
        single = np.ndim(frame) == 2
        frame = checks.array(frame[None] if single else frame, "frame", (self.batch, LOCOMOTION.n_joints, 3))
        _one_of(contacts, drawn)
        contact = self._detect(frame) if contacts is None else self._contacts(contacts, single)
        if drawn is not None:
            contact = contact | self._contacts(drawn, single, "drawn")
        in_contact = contact.reshape(-1, 2, 2)                                # (b, feet, ankle/toe)
        self.blocked &= in_contact.any(-1)                                    # a new contact may lock again
        active = in_contact.any(-1) & ~self.blocked                           # (b, feet)
        raw = frame[:, FEET]                                                  # (b, 4, 3)
        self._hold_and_let_go(raw, contact, active)
        if approach is None:
            approach = self.landing_guess(frame)
        else:
            approach = checks.array(approach[None] if single and np.ndim(approach) == 2 else approach, "approach",
                                    (self.batch, 4, 2))
        self.approach = np.where(np.repeat(active, 2, axis=1)[..., None], 0.0, approach)
        out = frame.copy()
        for leg in range(2):
            self._leg(frame, out, leg, contact, active)
        self.locked = active & ~self.blocked
        self.locked_frames += int(self.locked.sum())
        self.contact = contact
        self.previous = frame
        self.frames += 1
        return out[0] if single else out

    def landing_guess(self, frame: np.ndarray) -> np.ndarray:
        """The causal landing step for ``frame`` ``(batch, 21, 3)``: a horizontal shift ``(batch,
        4, 2)`` per foot joint, from this frame and the last one only. A joint ``h`` above its
        planted height that came down ``d`` since the last frame lands in about ``n = h / d``
        frames; it is drawn ahead by ``landing * n`` times its last horizontal step, weighted as
        :func:`approach_shift` weighs its shift (a smoothstep from 0, :data:`APPROACH_S` and a
        frame before the landing, as it nears, times how near the floor the joint is)."""
        if self.previous is None or self.landing == 0:
            return np.zeros((self.batch, 4, 2))
        now, before = frame[:, FEET], self.previous[:, FEET]                 # (b, 4, 3)
        height = np.maximum(now[..., 1] - self.floor, 0.0)
        fall = before[..., 1] - now[..., 1]                                   # metres this frame, > 0: coming down
        frames = np.where(fall > 1e-4, height / np.maximum(fall, 1e-4), np.inf)
        w = _landing_weight(frames, APPROACH_S * self.fps, height, self.height_m)
        n = np.where(w > 0, frames, 0.0)
        return (self.landing * w * n)[..., None] * (now[..., [0, 2]] - before[..., [0, 2]])

    def _hold_and_let_go(self, raw: np.ndarray, contact: np.ndarray, active: np.ndarray) -> None:
        """The feet's offsets ``O`` and height corrections for this frame (see the class)."""
        moved = np.zeros((self.batch, 4, 2)) if self.previous is None else \
            raw[..., [0, 2]] - self.previous[:, FEET][..., [0, 2]]
        in_contact = contact.reshape(-1, 2, 2)
        # held: each joint in contact now and a frame ago cancels its own horizontal motion;
        # a joint of a held foot that is not in contact follows the one that is
        holding = (contact & self.contact)[..., None]                         # (b, 4, 1)
        offset = np.where(holding, self.offset - moved, self.offset)
        other = offset.reshape(-1, 2, 2, 2)[:, :, ::-1].reshape(-1, 4, 2)     # the foot's other joint
        follows = (~contact & in_contact[:, :, ::-1].reshape(-1, 4))[..., None]
        offset = np.where(follows, other + FOLLOW * (offset - other), offset)
        # the lowest joint in contact is drawn to its planted height: fully while lower than
        # its contact height, less and less up to the release height (a foot lifting off is
        # not held down)
        heights = raw[..., 1].reshape(-1, 2, 2) - self.floor.reshape(2, 2)
        lowest = np.where(in_contact, heights, np.inf).argmin(-1)[..., None]            # (b, feet, 1)
        above = np.take_along_axis(heights, lowest, -1)[..., 0]
        limit = np.take_along_axis(np.broadcast_to(self.height_m.reshape(2, 2), heights.shape), lowest, -1)[..., 0]
        drop = -above * np.clip((RELEASE * limit - above) / ((RELEASE - 1) * limit), 0.0, 1.0)
        self.held = np.where(active, self.held + 1, 0)
        ramp = smoothstep(self.held / self.blend)
        # let go: both fade from where they were; the offset more slowly near the floor
        letting_go = self.locked & ~active
        joints_go = np.repeat(letting_go, 2, axis=1)
        self.let_go[joints_go] = self.offset[joints_go]
        self.lift_from[letting_go] = self.lift[letting_go]
        clear = (heights >= self.height_m.reshape(2, 2)).all(-1)
        self.age = np.where(active, np.inf, np.where(letting_go, 0, self.age + np.where(clear, 1.0, LOW_FADE)))
        self.lift_age = np.where(active, np.inf, np.where(letting_go, 0, self.lift_age + 1))
        fade = 1 - smoothstep(self.age / self.release)
        self.offset = np.where(np.repeat(active, 2, axis=1)[..., None], offset,
                               self.let_go * np.repeat(fade, 2, axis=1)[..., None])
        self.lift = np.where(active, ramp * drop + (1 - ramp) * self.lift,
                             self.lift_from * (1 - smoothstep(self.lift_age / self.blend)))

    def _leg(self, frame: np.ndarray, out: np.ndarray, leg: int, contact: np.ndarray, active: np.ndarray) -> None:
        """Write leg ``leg``'s knee, ankle and toe into ``out``: IK to the ankle's target,
        the heel raised to pivot on a held toe beyond reach, the foot aimed at the toe."""
        hip, knee, ankle, toe = LEGS[leg]
        xz = self.offset + self.approach
        shift = [np.concatenate([xz[:, j, :1], self.lift[:, leg, None], xz[:, j, 1:]], -1)
                 for j in (2 * leg, 2 * leg + 1)]                              # ankle's, toe's (b, 3)
        hint = frame[:, toe] - frame[:, ankle]
        foot_length = np.linalg.norm(hint, axis=-1, keepdims=True)
        ankle_target, toe_target = frame[:, ankle] + shift[0], frame[:, toe] + shift[1]
        toe_held = contact[:, 2 * leg + 1, None] & active[:, leg, None]      # the ankle a foot from it
        ankle_target = np.where(toe_held, toe_target + foot_length * _unit(ankle_target - toe_target)[0],
                                ankle_target)
        reach = (np.linalg.norm(frame[:, knee] - frame[:, hip], axis=-1)
                 + np.linalg.norm(frame[:, ankle] - frame[:, knee], axis=-1)) * (1 - PIVOT_BEND)
        far = active[:, leg] & (np.linalg.norm(ankle_target - frame[:, hip], axis=-1) > reach)
        wanted, met = ankle_target.copy(), np.ones(self.batch, dtype=bool)
        if far.any():                                                         # pivot on the toe
            self.pivot_frames += int(far.sum())
            ankle_target[far], met[far] = _pivot(frame[far, hip], toe_target[far], reach[far], foot_length[far, 0],
                                                 ankle_target[far])
        new_knee, new_ankle, reached = two_bone_ik(frame[:, hip], frame[:, knee], frame[:, ankle], ankle_target,
                                                   pole_hint=hint, reach_slack_m=REACH_SLACK_M)
        lost = active[:, leg] & ~(reached & met)
        if lost.any():                           # out of reach: let go from where the foot got to
            self.reach_releases += int(lost.sum())
            self.blocked[lost, leg] = True
            got = (new_ankle - wanted)[lost][:, [0, 2]]
            for j in (2 * leg, 2 * leg + 1):
                self.offset[lost, j] += got
                self.let_go[lost, j] = self.offset[lost, j]
            self.lift_from[lost, leg] = self.lift[lost, leg]
            self.age[lost, leg] = self.lift_age[lost, leg] = 0
        aim, norm = _unit(toe_target - new_ankle)
        aim = np.where(norm[..., None] > 1e-9, aim, _unit(hint)[0])
        touched = ((shift[0] != 0) | (shift[1] != 0)).any(-1)                 # untouched legs stay exact
        out[touched, knee], out[touched, ankle] = new_knee[touched], new_ankle[touched]
        out[touched, toe] = (new_ankle + foot_length * aim)[touched]


@dataclass(frozen=True)
class Locked:
    """What :func:`lock` did: the locked ``positions`` (input's shape), the ``contacts``
    used ``(..., frames, 4)``, the share of foot-frames that were locked, how many locks
    let go because even a foot pivoting on its toe was out of the leg's reach, how many
    contacts began, and the share of locked foot-frames that pivoted on the toe."""

    positions: np.ndarray
    contacts: np.ndarray
    locked_share: float
    reach_releases: int
    contacts_started: int
    pivot_share: float = 0.0

    @property
    def out_of_reach(self) -> float:
        """The share of contacts whose lock let go early because the leg could not reach."""
        return self.reach_releases / max(self.contacts_started, 1)


def _landing_weight(frames_to_land, steps: float, above_m, contact_height_m) -> np.ndarray:
    """How far a landing step draws a foot joint towards where it lands (the offline
    :func:`approach_shift` and :class:`FootLock`'s guess): a smoothstep from 0, ``steps + 1``
    frames before the landing, as ``frames_to_land`` nears, times how near the floor the
    joint is (``above_m`` over its planted height: 1 on it, 0 from :data:`APPROACH_HEIGHT`
    times ``contact_height_m`` up)."""
    soon = frames_to_land < steps + 1
    n = np.where(soon, frames_to_land, 0.0)
    near = 1 - smoothstep(above_m / (APPROACH_HEIGHT * np.asarray(contact_height_m)))
    return np.where(soon, smoothstep(1 - n / (steps + 1)), 0.0) * near


def approach_shift(positions, contacts, fps: float, planted_height_m, approach_s: float = APPROACH_S) -> np.ndarray:
    """For the frames just before each contact begins, the horizontal shift ``(..., frames,
    4, 2)`` (x, z) that draws each foot joint of ``positions`` ``(..., frames, 21, 3)``
    towards the spot where it lands: ``w (spot - p_t)``, with ``w`` a smoothstep from 0,
    ``approach_s`` before the landing, to nearly 1 the frame before it, times how near the
    floor the joint is (1 on it, 0 from :data:`APPROACH_HEIGHT` times its contact height up).

    A generated foot often comes down still sliding forward: it is low, but too fast to be
    held, for a frame or two before the lock holds it, and that is sliding on the floor.
    The data's feet slow down in the air and land almost still. Knowing where the foot
    lands (later frames: offline only), the lock moves it there a little early, while it is
    low. A foot in the air is not moved, and the landing spot is the motion's own."""
    positions = _positions(positions)
    contacts = _contact_array(contacts, positions.shape[:-2] + (len(FEET),))
    planted_height_m = _per_foot_joint(planted_height_m, "planted_height_m", positive=False)
    frames = positions.shape[-3]
    steps = checks.non_negative(approach_s, "approach_s", checks.MAX_SECONDS) * checks.rate(fps, "fps")
    feet = positions[..., FEET, :]
    xz = feet[..., [0, 2]]                                                  # (..., frames, 4, 2)
    above = feet[..., 1] - planted_height_m                                  # (..., frames, 4)
    shift = np.zeros(xz.shape)
    until = np.full(contacts.shape[:-2] + (len(FEET),), np.inf)              # frames to the next landing
    spot = np.zeros(xz.shape[:-3] + xz.shape[-2:])
    for t in range(frames - 2, -1, -1):
        lands = contacts[..., t + 1, :] & ~contacts[..., t, :]
        until = np.where(contacts[..., t, :], np.inf, np.where(lands, 1.0, until + 1))
        spot = np.where(lands[..., None], xz[..., t + 1, :, :], spot)
        w = _landing_weight(until, steps, above[..., t, :], CONTACT_HEIGHT_M)
        shift[..., t, :, :] = w[..., None] * (spot - xz[..., t, :, :])
    return shift


def _one_of(contacts, drawn) -> None:
    """``ValueError`` naming ``drawn`` when both are given: ``contacts`` replace the detector's,
    ``drawn`` (a contact head's) add to them."""
    if contacts is not None and drawn is not None:
        raise ValueError("drawn: give the contacts to hold (contacts) or the model's own to add to the "
                         "detector's (drawn), not both")


def lock(positions, fps: float, contacts=None, planted_height_m=None, blend_s: float = BLEND_S,
         approach_s: float = APPROACH_S, drawn=None) -> Locked:
    """:func:`lock_feet`, and what it did (:class:`Locked`). ``approach_s`` (0: none): how
    long before landing a low foot is slowed into its spot (:func:`approach_shift`).
    ``drawn``: with ``contacts`` None, the contacts a model with a contact head drew
    (``Generated.contacts``, ``(..., frames, 4)`` booleans), added to the ones detected: a
    foot joint is held where the detector *or* the model says it is down."""
    positions = _positions(positions)
    fps = checks.rate(fps, "fps")
    frames = positions.shape[-3]
    blend = checks.non_negative(blend_s, "blend_s", checks.MAX_SECONDS)
    if frames < max(2, int(np.ceil(blend * fps))):
        raise ValueError(f"positions: the clip has {frames} frames, fewer than the {blend:g}-s blend "
                         f"({int(np.ceil(blend * fps))} frames at {fps:g} fps) and at least 2")
    floor = planted_heights(positions) if planted_height_m is None else \
        _per_foot_joint(planted_height_m, "planted_height_m", positive=False)
    _one_of(contacts, drawn)
    contacts = detect(positions, fps, floor) if contacts is None else \
        _contact_array(contacts, positions.shape[:-2] + (4,))
    if drawn is not None:
        contacts = contacts | _contact_array(drawn, positions.shape[:-2] + (4,), "drawn")
    flat = positions.reshape(-1, frames, LOCOMOTION.n_joints, 3)
    flat_contacts = contacts.reshape(-1, frames, 4)
    approach = approach_shift(flat, flat_contacts, fps, floor, approach_s)
    locker = FootLock(fps, len(flat), floor, blend_s=blend)
    out = np.empty_like(flat)
    for t in range(frames):
        out[:, t] = locker.step(flat[:, t], flat_contacts[:, t], approach[:, t])
    foot = flat_contacts.reshape(len(flat), frames, 2, 2).any(-1)
    started = int(foot[:, 0].sum() + (foot[:, 1:] & ~foot[:, :-1]).sum())      # contacts that began
    return Locked(out.reshape(positions.shape), contacts, locker.locked_frames / (2 * len(flat) * frames),
                  locker.reach_releases, started, locker.pivot_frames / max(locker.locked_frames, 1))


def lock_feet(positions, fps: float, contacts=None, planted_height_m=None) -> np.ndarray:
    """World positions ``(..., frames, 21, 3)`` with the feet locked while in contact.

    ``contacts`` ``(..., frames, 4)`` (:data:`FEET` order) or None: detected on the motion
    itself (:func:`detect`, with ``planted_height_m``: the data's planted heights, or
    default the motion's own). While a foot is in contact it stays where it landed, on the
    floor; the leg reaches it by two-bone IK; nothing above the hips moves; the lock lets
    go when the contact ends or the leg cannot reach, blending over :data:`BLEND_S`. The
    same lock as :class:`FootLock` (causal) run over the clip, given the offline labels,
    and slowing a landing foot into its spot (:func:`approach_shift`), which the causal
    lock cannot know.
    """
    return lock(positions, fps, contacts, planted_height_m).positions


# ----------------------------------------------------------------------------------------
# 3. Bones that keep their length
# ----------------------------------------------------------------------------------------

def fit_bones(positions, lengths=None, keep_feet: bool = True, skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """``positions`` ``(..., frames, joints, 3)`` put back onto a skeleton whose bones keep
    one length: walking down the tree from the root (which stays), each joint is placed at
    its bone's length from its (already placed) parent, along the bone's direction in
    ``positions``.

    ``lengths``: ``(joints - 1,)`` in ``skeleton.bones`` order, metres; default each
    bone's median length over the frames of each clip (so a body keeps its own size, and
    its bones stop stretching). Pass the data's to give every sample the data's body.

    ``keep_feet`` (locomotion skeleton only): the legs are not walked down but reach the
    ankles where the motion had them, by :func:`two_bone_ik` (knee in the plane it bent in),
    and the foot points at the motion's toe. Rescaling a leg bone by bone would move the
    feet by the stretch of every bone above them, frame by frame: new sliding."""
    positions = checks.array(positions, "positions", (..., "frames", skeleton.n_joints, 3))
    bones = skeleton.bones
    if lengths is None:
        lengths = np.median(skeleton.bone_lengths(positions), axis=-2, keepdims=True)   # (..., 1, bones)
    else:
        lengths = checks.array(lengths, "lengths", (len(bones),))
        if not (lengths > 0).all():
            raise ValueError("lengths: every bone length must be > 0")
    out = positions.copy()
    for k, (parent, child) in enumerate(bones):
        direction, _ = _unit(positions[..., child, :] - positions[..., parent, :])
        out[..., child, :] = out[..., parent, :] + lengths[..., k, None] * direction
    if keep_feet and skeleton.names == LOCOMOTION.names:
        for hip, knee, ankle, toe in LEGS:
            out[..., knee, :], out[..., ankle, :], _ = two_bone_ik(
                out[..., hip, :], out[..., knee, :], out[..., ankle, :], positions[..., ankle, :],
                pole_hint=positions[..., toe, :] - positions[..., ankle, :])
            aim, _ = _unit(positions[..., toe, :] - out[..., ankle, :])
            out[..., toe, :] = out[..., ankle, :] + lengths[..., bones.index((ankle, toe)), None] * aim
    return out


def body_lengths(positions, skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """The bone lengths of the body in ``positions`` ``(..., frames, joints, 3)``: each bone's
    median over every frame and clip, ``(joints - 1,)`` in ``skeleton.bones`` order, metres.
    Of the data's bodies, what :func:`finish` puts a model's samples back onto."""
    positions = checks.array(positions, "positions", (..., "frames", skeleton.n_joints, 3))
    return np.median(skeleton.bone_lengths(positions).reshape(-1, len(skeleton.bones)), axis=0)


# ----------------------------------------------------------------------------------------
# From a model's features to a character: bones, then feet
# ----------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Finished:
    """What :func:`finish` made: ``features`` ``(..., frames, 66)`` on the input's own root
    path (measure them as the raw ones), the world ``positions`` ``(..., frames, 21, 3)``,
    and ``lock`` (:class:`Locked`, or None when the feet were not locked)."""

    features: np.ndarray
    positions: np.ndarray
    lock: Locked | None


def finish(features, fps: float, planted_height_m=None, bone_lengths=None, fit: bool = True,
           lock_feet: bool = True, drawn=None) -> Finished:
    """A model's features ``(..., frames, 66)`` (data units) made into a character: world
    positions (:func:`representation.to_positions`), every bone back to one length
    (:func:`fit_bones`, feet kept where they were), then the feet locked (:func:`lock`,
    contacts detected with the data's ``planted_height_m``). The root path is not touched,
    so the finished features follow the same control.

    ``bone_lengths``: the bones every sample is put back onto, e.g. the data's
    (:func:`body_lengths`); default each bone's median in the sample itself. The median is
    too long for a model whose bones keep growing as it goes (an anchored MoGlow's shins),
    but a sample's feet were placed by its own legs: on the data's, a lock holding them
    needs legs of another length, and its planted feet move more (docs/feet.md).

    ``drawn``: the contacts a model with a contact head drew (``Generated.contacts``), held
    as well as the detected ones (:func:`lock`)."""
    features = checks.array(features, "features", (..., "frames", 3 * LOCOMOTION.n_joints + 3))
    fps = checks.rate(fps, "fps")
    positions = to_positions(features, fps)
    if fit:
        positions = fit_bones(positions, bone_lengths)
    locked = lock(positions, fps, planted_height_m=planted_height_m, drawn=drawn) if lock_feet else None
    positions = locked.positions if locked is not None else positions
    return Finished(along_path(positions, features[..., -3:], fps), positions, locked)


# ----------------------------------------------------------------------------------------
# 4. A training term: planted feet's world velocity, from features (HuMoR, EDGE, MDM)
# ----------------------------------------------------------------------------------------

def foot_velocity(features, fps: float):
    """Horizontal world velocity of the ankles and toes, m/s, from features in data units
    (``(..., frames, 66)``, a torch tensor, differentiable): ``(..., frames - 1, 4, 2)``,
    ``(x, z)`` in the axes of frame ``t``'s root.

    A foot at root-local ``p_t`` is at ``R(θ) p_{t+1} + s_t`` a frame later, seen from
    frame ``t``'s root: the root turned by ``θ = turning / fps`` and stepped by
    ``s_t = (sideways, forward) / fps`` (the control of frame ``t``). So its velocity is
    ``(R(θ) p_{t+1} + s_t − p_t) · fps``: what a planted foot must keep at zero, and what the
    root-local pose alone cannot see."""
    import torch
    fps = checks.rate(fps, "fps")
    if not isinstance(features, torch.Tensor) or features.shape[-1] != 3 * LOCOMOTION.n_joints + 3 \
            or features.ndim < 2 or features.shape[-2] < 2:
        raise ValueError(f"features: expected a tensor (..., frames >= 2, {3 * LOCOMOTION.n_joints + 3}), "
                         f"got {type(features).__name__} {tuple(getattr(features, 'shape', ()))}")
    n_pose = 3 * LOCOMOTION.n_joints
    pose = features[..., :n_pose].unflatten(-1, (LOCOMOTION.n_joints, 3))[..., FEET, :]
    x, z = pose[..., 0], pose[..., 2]                                     # (..., frames, 4)
    control = features[..., :-1, n_pose:]
    theta = (control[..., 2] / fps)[..., None]
    c, s = torch.cos(theta), torch.sin(theta)
    x1, z1 = x[..., 1:, :], z[..., 1:, :]
    vx = (c * x1 + s * z1 + control[..., 1:2] / fps - x[..., :-1, :]) * fps
    vz = (-s * x1 + c * z1 + control[..., 0:1] / fps - z[..., :-1, :]) * fps
    return torch.stack([vx, vz], dim=-1)


def contact_labels(features, fps: float, planted_height_m=PLANTED_HEIGHT_M, height_m=CONTACT_HEIGHT_M,
                   speed_ms: float = CONTACT_SPEED_MS):
    """Contact labels of *data* features (a torch tensor ``(..., frames, 66)``, data units)
    for the training term: ``(..., frames - 1, 4)`` floats, 1 where an ankle / toe is below
    its contact height above ``planted_height_m`` in frames ``t`` and ``t + 1`` and moves
    slower than ``speed_ms`` (:func:`foot_velocity`). The per-frame rule of :func:`detect`,
    without its hysteresis and filter (data's contacts are clean)."""
    import torch
    fps = checks.rate(fps, "fps")
    floor = torch.as_tensor(_per_foot_joint(planted_height_m, "planted_height_m", positive=False),
                            dtype=features.dtype, device=features.device)
    limit = torch.as_tensor(_per_foot_joint(height_m, "height_m"), dtype=features.dtype, device=features.device)
    n_pose = 3 * LOCOMOTION.n_joints
    height = features[..., :n_pose].unflatten(-1, (LOCOMOTION.n_joints, 3))[..., FEET, 1] - floor
    low = height < limit
    slow = foot_velocity(features, fps).norm(dim=-1) < checks.positive(speed_ms, "speed_ms")
    return (low[..., 1:, :] & low[..., :-1, :] & slow).to(features.dtype)


def contact_velocity_loss(prediction, target, fps: float):
    """The foot-contact velocity term, ``mean(labels · |v|²)`` in (m/s)²: ``labels`` the
    planted ankles and toes of the data ``target`` (:func:`contact_labels`), ``v`` the same
    joints' world velocity in ``prediction`` (:func:`foot_velocity`). Both torch tensors
    ``(..., frames >= 2, 66)`` in data units; the mean is over frame pairs, foot joints and
    the batch, and the gradient flows through ``prediction`` only.

    MDM (Tevet et al. 2023) adds this term with the data's contacts, as here; HuMoR (Rempe
    et al. 2021) and EDGE (Tseng et al. 2023) penalise the same velocity on contacts their
    model predicts. A planted foot of the data must not move in the world in the model's
    motion: what a root-local reconstruction error does not see (:func:`foot_velocity`)."""
    import torch
    if not (isinstance(prediction, torch.Tensor) and isinstance(target, torch.Tensor)) \
            or prediction.shape != target.shape:
        raise ValueError(f"prediction, target: expected two tensors of one shape (..., frames, 66), got "
                         f"{tuple(getattr(prediction, 'shape', ()))} and {tuple(getattr(target, 'shape', ()))}")
    with torch.no_grad():
        labels = contact_labels(target, fps)
    return (labels * foot_velocity(prediction, fps).square().sum(-1)).mean()
