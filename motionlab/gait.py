"""The synthetic walker: a control trajectory in, a walking, jogging or running body out.

A control trajectory (forward, sideways and turning velocity per frame: the same three
numbers as the control part of :mod:`motionlab.representation`) drives a body of 21 joints:

1. **Root path** (:func:`root_path`). The control is integrated into the path of the
   root on the floor.
2. **Gait timing** (:func:`gait_timing`). A stride phase advances at a cadence set by the
   speed, as in human gait: about 1.6-2.0 steps/s for walking, 2.6-3.0 steps/s for
   running. Each foot is on the floor (*stance*) for a fraction of the stride: about 62 %
   when walking (both feet down part of the time), about 36 % when running (a flight
   phase with both feet up).
3. **Footsteps** (:func:`footsteps`). Each stance places the foot on the floor beside the
   root's position at mid-stance, and there it stays: the ankle until the heel lifts,
   then the toes. Between stances the foot swings along a smooth arc to the next footstep.
4. **Pelvis** (:func:`pelvis_motion`). It follows the root with a side-to-side sway and a
   twist per stride, and rides as high as the legs can reach the planted feet (which
   gives the walking bob); running adds a bounce, lowest at mid-stance.
5. **Legs** (:func:`legs`) by two-bone inverse kinematics from each hip to its ankle,
   knees forward.
6. **Upper body** (:func:`upper_body`) by forward kinematics: spine leaning into speed and
   turns and twisting against the pelvis, a steady head, arms swinging against the legs,
   elbows bent more when running.

:func:`generate` runs the six steps in order, one function each, all per padded frame.
A clip's :class:`Body` (proportions within human ranges, constant bone lengths) and
:class:`Style` (stride, step width, toe-out, arm swing, elbow bend, lean, bounce, asymmetry)
are given or drawn (``Body.random``, ``Style.random``). Everything is vectorised over frames;
:func:`generate` draws no random numbers. What the walker follows and the data set made of it
are :mod:`motionlab.synthetic`, where these names are importable too.

Positions are metres, y up, floor at y = 0; angles in :class:`Style` are degrees.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from . import checks
from .filters import gaussian_smooth, smoothstep
from .representation import integrate_control
from .rotations import axis_rotation, y_rotation
from .skeleton import LOCOMOTION

GRAVITY = 9.81
J = {name: i for i, name in enumerate(LOCOMOTION.names)}


# ----------------------------------------------------------------------------------------
# Bodies and styles
# ----------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Body:
    """Body proportions in metres (defaults: the mean of the CMU subjects, about 1.75 m).

    Offsets are in the body frame: ``x`` left, ``y`` up, ``z`` forward.
    """

    hip_offset: tuple[float, float, float] = (0.09, -0.10, 0.04)   # pelvis -> left hip
    thigh: float = 0.41
    shin: float = 0.435
    ankle_height: float = 0.085       # ankle joint above the floor, foot flat
    toe_height: float = 0.035         # toe joint above the floor, foot flat
    foot_length: float = 0.118        # ankle to toe joint, along the floor
    lower_back: float = 0.118
    upper_back: float = 0.118
    neck: float = 0.096
    head: float = 0.097
    shoulder_offset: tuple[float, float, float] = (0.185, 0.065, -0.03)  # chest -> left shoulder
    upper_arm: float = 0.298
    forearm: float = 0.206
    hand: float = 0.036

    def __post_init__(self):
        checks.config(self, positive_fields=tuple(f.name for f in fields(self) if f.type == "float"))
        for name in ("hip_offset", "shoulder_offset"):
            object.__setattr__(self, name, tuple(checks.array(getattr(self, name), name, (3,)).tolist()))

    @classmethod
    def random(cls, rng: np.random.Generator) -> "Body":
        """A body scaled to 0.92-1.08 of the default, with a few percent of independent
        variation per segment (legs, trunk, arms, shoulders)."""
        base = cls()
        scale = rng.uniform(0.92, 1.08)
        leg, trunk, arm, width = rng.normal(1.0, 0.025, 4).clip(0.93, 1.07)

        def s(value, *factors):
            out = np.asarray(value, dtype=float) * scale * np.prod(factors)
            return tuple(out) if out.ndim else float(out)

        hip = np.array(base.hip_offset) * scale * np.array([width, 1, 1])
        return cls(hip_offset=tuple(hip), thigh=s(base.thigh, leg), shin=s(base.shin, leg),
                   ankle_height=s(base.ankle_height), toe_height=s(base.toe_height),
                   foot_length=s(base.foot_length, leg), lower_back=s(base.lower_back, trunk),
                   upper_back=s(base.upper_back, trunk), neck=s(base.neck, trunk),
                   head=s(base.head), shoulder_offset=s(base.shoulder_offset, width),
                   upper_arm=s(base.upper_arm, arm), forearm=s(base.forearm, arm),
                   hand=s(base.hand, arm))

    @property
    def leg_length(self) -> float:
        return self.thigh + self.shin

    @property
    def toe_offset(self) -> np.ndarray:
        """Ankle -> toe joint with the foot flat, ``(3,)``, foot frame."""
        return np.array([0.0, self.toe_height - self.ankle_height, self.foot_length])


@dataclass(frozen=True)
class Style:
    """How one person moves. Each field is a factor on the typical value (1.0) or an angle
    in degrees; :meth:`random` draws them from human-like ranges."""

    cadence: float = 1.0          # steps per second, as a factor
    step_width: float = 0.12      # distance between the feet's tracks, metres
    toe_out: float = 6.0          # feet turned outwards, degrees
    arm_swing: float = 1.0        # factor on the arm swing amplitude
    elbow_bend: float = 0.0       # extra elbow flexion, degrees
    lean: float = 0.0             # extra forward lean of the trunk, degrees
    bounce: float = 1.0           # factor on the vertical bounce
    sway: float = 1.0             # factor on the pelvis side-to-side sway and twist
    knee_reach: float = 0.975     # how straight the stance leg gets (fraction of its length)
    asymmetry: float = 0.0        # left arm swings (1 + a) times, right arm (1 - a) times
    run_speed: float = 2.2        # forward speed (m/s) at the middle of the walk-run transition
    clearance: float = 1.0        # factor on how high the swinging foot lifts

    def __post_init__(self):
        checks.config(self, positive_fields=("cadence", "knee_reach", "run_speed"),
                      non_negative_fields=("step_width", "arm_swing", "bounce", "sway", "clearance"))

    @classmethod
    def random(cls, rng: np.random.Generator) -> "Style":
        return cls(cadence=rng.uniform(0.95, 1.05), step_width=rng.uniform(0.08, 0.17),
                   toe_out=rng.uniform(0.0, 12.0), arm_swing=rng.uniform(0.6, 1.4),
                   elbow_bend=rng.uniform(-8.0, 15.0), lean=rng.uniform(-2.0, 4.0),
                   bounce=rng.uniform(0.7, 1.3), sway=rng.uniform(0.7, 1.3),
                   knee_reach=rng.uniform(0.965, 0.985), asymmetry=rng.uniform(-0.15, 0.15),
                   run_speed=rng.uniform(2.0, 2.4), clearance=rng.uniform(0.8, 1.2))


# ----------------------------------------------------------------------------------------
# Helpers
# ----------------------------------------------------------------------------------------

def _apply(rotations: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """``(F, 3, 3) @ (F, 3)`` or ``(F, 3, 3) @ (3,)`` -> ``(F, 3)``."""
    return np.einsum("fab,fb->fa", rotations, np.broadcast_to(vectors, rotations.shape[:-1]))


def _soft_min(*values: np.ndarray, softness: float = 0.01) -> np.ndarray:
    """A smooth minimum, never above the true minimum."""
    stack = np.stack(values)
    low = stack.min(axis=0)
    return low - softness * np.log(np.exp(-(stack - low) / softness).sum(axis=0))


def _two_bone_ik(hip: np.ndarray, ankle: np.ndarray, pole: np.ndarray, upper: float,
                 lower: float) -> tuple[np.ndarray, np.ndarray]:
    """Knee positions ``(F, 3)`` putting the ankle at ``ankle`` with the knee towards ``pole``.

    An ankle out of reach is pulled in along the hip-ankle line (returned as the second
    value), so bone lengths always stay exact.
    """
    to_ankle = ankle - hip
    dist = np.linalg.norm(to_ankle, axis=-1, keepdims=True)
    reach = np.clip(dist, abs(upper - lower) + 1e-6, (upper + lower) * (1 - 1e-9))
    direction = to_ankle / dist
    ankle = hip + direction * reach
    cos_hip = (upper ** 2 + reach ** 2 - lower ** 2) / (2 * upper * reach)
    bend = pole - np.sum(pole * direction, axis=-1, keepdims=True) * direction
    bend /= np.linalg.norm(bend, axis=-1, keepdims=True)
    knee = hip + upper * (cos_hip * direction + np.sqrt(1 - cos_hip ** 2) * bend)
    return knee, ankle


# ----------------------------------------------------------------------------------------
# The generator: one function per step of the module docstring, all per padded frame
# ----------------------------------------------------------------------------------------

@dataclass
class Motion:
    """One generated clip.

    Attributes:
        positions: ``(frames, 21, 3)`` world positions of the locomotion skeleton, metres.
        control: ``(frames, 3)`` the commanded forward, sideways (m/s), turning (rad/s).
        contacts: ``(frames, 2)`` bool, left and right foot in stance.
        fps: frames per second.
        body, style: what was drawn for this clip.
    """

    positions: np.ndarray
    control: np.ndarray
    contacts: np.ndarray
    fps: float
    body: Body
    style: Style


@dataclass
class Gait:
    """Step 2, the gait timing: ``(frames,)`` arrays over the padded clip."""

    t: np.ndarray                 # time, seconds
    planar: np.ndarray            # horizontal speed, m/s
    active: np.ndarray            # 0 standing .. 1 moving
    running: np.ndarray           # 0 walking .. 1 running
    stance_fraction: np.ndarray   # fraction of a stride each foot is down
    stride_s: np.ndarray          # seconds per stride (two steps)
    cycles: np.ndarray            # strides of the left foot so far, from the start phase
    forwardness: np.ndarray       # 0 .. 1: how much the feet roll heel to toe


@dataclass
class Foot:
    """Step 3, one foot over the padded clip."""

    stance: np.ndarray            # (frames,) bool, on the floor
    u: np.ndarray                 # (frames,) where in its stride, 0 .. 1
    beta: np.ndarray              # (frames,) the stance fraction of that stride
    swing_u: np.ndarray           # (frames,) how far through the swing, 0 .. 1 (0 in stance)
    ankle: np.ndarray             # (frames, 3) ankle position, metres
    rotation: np.ndarray          # (frames, 3, 3) the foot's rotation (flat, facing +z: identity)


@dataclass
class Pelvis:
    """Step 4, the pelvis over the padded clip."""

    hips: np.ndarray              # (frames, 3) the Hips joint, metres
    rotation: np.ndarray          # (frames, 3, 3)
    hip_offsets: dict             # "Left"/"Right" -> (frames, 3) hip joint minus hips, metres
    twist: np.ndarray             # (frames,) about the vertical, degrees, left hip forward
    list_angle: np.ndarray        # (frames,) sideways tilt, degrees


def cadence_steps_per_s(speed: np.ndarray, run_blend: np.ndarray) -> np.ndarray:
    """Steps per second at forward ``speed`` (m/s), blending walking (0) and running (1).

    Walking: 1.5 + 0.22 v (1.7 steps/s at 0.9 m/s, 1.9 at 1.8 m/s); running: 2.5 + 0.1 v.
    """
    speed = np.abs(speed)
    walk = 1.5 + 0.22 * np.minimum(speed, 2.0)
    run = 2.5 + 0.1 * np.minimum(speed, 5.0)
    return (1 - run_blend) * walk + run_blend * run


def padding_frames(fps: float) -> int:
    """Frames of padding either side of the clip (a second), so footsteps exist at the edges."""
    return int(np.ceil(fps))


def root_path(control: np.ndarray, fps: float, start: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """Step 1: the control padded by :func:`padding_frames` either side (repeating its
    first and last frame), ``(frames, 3)``, and the root ``(x, z, heading)`` per padded
    frame, ``(frames, 3)``, placed so that the clip's first frame is at ``start``."""
    pad = padding_frames(fps)
    padded = np.pad(control, ((pad, pad), (0, 0)), mode="edge")
    root = integrate_control(padded, fps)
    start = np.zeros(3) if start is None else np.asarray(start, dtype=np.float64)
    turn = start[2] - root[pad, 2]                              # move the path rigidly so
    rel = np.stack([root[:, 0] - root[pad, 0], np.zeros(len(root)), root[:, 1] - root[pad, 1]], -1)
    rel = rel @ y_rotation(turn).T                              # that frame `pad` is `start`
    root = np.stack([start[0] + rel[:, 0], start[1] + rel[:, 2], root[:, 2] + turn], -1)
    return padded, root


def gait_timing(padded: np.ndarray, fps: float, style: Style, phase: float = 0.0) -> Gait:
    """Step 2: how active (0 standing .. 1 moving), how much running, and the stride phase
    (starting at ``phase`` strides) for the padded control ``(frames, 3)``."""
    forward, sideways, turning = padded.T
    smooth = lambda x: gaussian_smooth(x, 0.15 * fps)  # noqa: E731
    planar = np.hypot(forward, sideways)
    active = smooth(smoothstep(np.maximum(planar / 0.5, np.abs(turning) / 0.8)))
    running = smooth(smoothstep((forward - style.run_speed + 0.3) / 0.6))
    cadence = style.cadence * cadence_steps_per_s(planar, running)
    stance_fraction = ((1 - running) * (0.64 - 0.02 * np.minimum(planar, 2.0))
                       + running * (0.40 - 0.025 * np.minimum(planar, 5.0)))
    stride_s = 2.0 / cadence
    cycles = phase + np.concatenate([[0.0], np.cumsum(0.5 * (cadence[1:] + cadence[:-1]) / 2 / fps)])
    forwardness = smooth(smoothstep(forward / 1.0))          # heel-toe roll when going forwards
    return Gait(np.arange(len(padded)) / fps, planar, active, running, stance_fraction, stride_s,
                cycles, forwardness)


def _stance_times(gait: Gait, c: np.ndarray, cycle_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each of a foot's strides ``cycle_ids`` (its stride count per frame: ``c``), the
    stance fraction and the time of mid-stance, extrapolated past the padded clip."""
    t = gait.t
    # times of each cycle's start and mid-stance (extrapolated past the padded clip)
    slope = 1.0 / (c[-1] - c[0]) * (t[-1] - t[0])
    cycle_t = np.interp(cycle_ids, c, t, left=np.nan, right=np.nan)
    cycle_t = np.where(np.isnan(cycle_t), t[0] + (cycle_ids - c[0]) * slope, cycle_t)
    beta_k = np.interp(cycle_t, t, gait.stance_fraction)
    # the foot is under the hips a little before mid-stance when running
    under = beta_k * (0.5 - 0.12 * np.interp(cycle_t, t, gait.running))
    mid_t = np.interp(cycle_ids + under, c, t, left=np.nan, right=np.nan)
    mid_t = np.where(np.isnan(mid_t), t[0] + (cycle_ids + under - c[0]) * slope, mid_t)
    return beta_k, np.clip(mid_t, t[0], t[-1])


def footsteps(root: np.ndarray, padded: np.ndarray, gait: Gait, body: Body,
              style: Style) -> dict[str, Foot]:
    """Step 3: both feet (``"Left"``, ``"Right"``), the right half a stride after the left.

    Each stance plants the foot beside the root at mid-stance, wider when side-stepping
    so the feet never cross, turned out by the style's toe-out; it stays there, the ankle
    until the heel lifts, then the toes. Between stances the foot swings along a smooth arc.
    """
    t, sideways = gait.t, padded[:, 1]

    def at(times: np.ndarray, values: np.ndarray) -> np.ndarray:
        return np.interp(times, t, values)

    feet = {}
    for side, sign, offset in (("Left", 1.0, 0.0), ("Right", -1.0, 0.5)):
        c = gait.cycles + offset                                # this foot's stride count
        k = np.floor(c).astype(int)
        u = c - k                                               # 0..1 within the stride
        first = k.min() - 1
        beta_k, mid_t = _stance_times(gait, c, np.arange(first, k.max() + 3))

        # where each footstep is, how the foot is turned there
        heading_k = at(mid_t, root[:, 2])
        half_width = style.step_width / 2 + np.abs(at(mid_t, sideways)) * at(mid_t, gait.stride_s) / 4
        lateral = np.stack([sign * half_width, np.zeros_like(half_width), np.zeros_like(half_width)], -1)
        plant = np.stack([at(mid_t, root[:, 0]), np.zeros_like(mid_t), at(mid_t, root[:, 1])], -1)
        plant += _apply(y_rotation(heading_k), lateral)
        plant[:, 1] = body.ankle_height
        yaw_k = np.rad2deg(heading_k) + sign * style.toe_out
        roll = at(mid_t, gait.forwardness) * at(mid_t, gait.active)
        strike_k = -12.0 * roll                                  # toes up at heel strike
        lift_k = (30.0 + 25.0 * at(mid_t, gait.running)) * roll  # heel up at toe-off
        foot_rot_k = axis_rotation("Y", yaw_k)
        toe_plant = plant + _apply(foot_rot_k, body.toe_offset)
        lift_ankle = toe_plant - _apply(foot_rot_k @ axis_rotation("X", lift_k), body.toe_offset)

        i = k - first                                            # index of this frame's cycle
        beta = beta_k[i]
        stance = u < beta
        # stance: flat then heel rising about the toe (the planted joints stay put)
        us = np.clip(u / beta, 0, 1)
        heel_off = us > 0.55
        pitch_stance = np.where(us < 0.25, strike_k[i] * (1 - us / 0.25), 0.0)
        pitch_stance = np.where(heel_off, lift_k[i] * ((us - 0.55) / 0.45) ** 2, pitch_stance)
        stance_rot = axis_rotation("Y", yaw_k[i]) @ axis_rotation("X", pitch_stance)
        ankle_stance = np.where(heel_off[:, None], toe_plant[i] - _apply(stance_rot, body.toe_offset),
                                plant[i])
        # swing: lift-off ankle -> next footstep along a smooth arc
        uw = np.clip((u - beta) / (1 - beta), 0, 1)
        s = 0.5 - 0.5 * np.cos(np.pi * uw)
        ankle_swing = lift_ankle[i] + s[:, None] * (plant[i + 1] - lift_ankle[i])
        lift_height = (0.07 + 0.2 * gait.running) * style.clearance * gait.active
        peak_early = uw ** (1 - 0.35 * gait.running)           # running: heel kicks up behind
        ankle_swing[:, 1] += lift_height * np.sin(np.pi * peak_early) ** 1.5
        pitch_swing = lift_k[i] + s * (strike_k[i + 1] - lift_k[i])
        yaw_swing = yaw_k[i] + s * (yaw_k[i + 1] - yaw_k[i])
        swing_rot = axis_rotation("Y", yaw_swing) @ axis_rotation("X", pitch_swing)

        feet[side] = Foot(stance, u, beta, np.where(stance, 0.0, uw),
                          np.where(stance[:, None], ankle_stance, ankle_swing),
                          np.where(stance[:, None, None], stance_rot, swing_rot))
    return feet


def pelvis_motion(root: np.ndarray, gait: Gait, feet: dict[str, Foot], body: Body,
                  style: Style) -> Pelvis:
    """Step 4: the pelvis sways towards the stance foot, twists with the legs, lists, and
    rides as high as the legs reach the planted feet (the walking bob), plus a bounce."""
    frames = len(root)
    active, running, planar = gait.active, gait.running, gait.planar
    left_u, beta = feet["Left"].u, gait.stance_fraction
    stride_wave = np.cos(2 * np.pi * (left_u - beta / 2))      # +1 at left mid-stance
    step_wave = np.cos(4 * np.pi * (left_u - beta / 2))        # +1 at each mid-stance
    sway = 0.025 * style.sway * active * (1 - 0.6 * running) * stride_wave
    twist = -5.0 * style.sway * active * np.cos(2 * np.pi * left_u)   # degrees, left hip forward
    tilt = 6.0 + 2.0 * running
    list_ = 3.0 * style.sway * active * stride_wave
    pelvis_rot = (axis_rotation("Y", np.rad2deg(root[:, 2]) + twist)
                  @ axis_rotation("X", np.broadcast_to(tilt, twist.shape)) @ axis_rotation("Z", list_))
    pelvis_xz = np.stack([root[:, 0], np.zeros(frames), root[:, 1]], -1) + _apply(
        y_rotation(root[:, 2]), np.stack([sway, np.zeros(frames), np.zeros(frames)], -1))
    hip_local = {side: np.array(body.hip_offset) * [sign, 1, 1]
                 for side, sign in (("Left", 1.0), ("Right", -1.0))}
    hip_from_pelvis = {side: _apply(pelvis_rot, off) for side, off in hip_local.items()}
    reach = style.knee_reach * body.leg_length
    highest = []
    for side in ("Left", "Right"):
        hip_xz = pelvis_xz + hip_from_pelvis[side] * [1, 0, 1]
        ankle = feet[side].ankle
        horizontal = np.linalg.norm((ankle - hip_xz)[:, [0, 2]], axis=-1)
        vertical = np.sqrt(np.maximum(reach ** 2 - horizontal ** 2, 0.01))
        # a swinging leg can bend its knee: it only holds the pelvis down near touchdown
        # and lift-off, so the constraint fades in and out smoothly
        slack = 0.4 * active * np.sin(np.pi * feet[side].swing_u) ** 2
        highest.append(ankle[:, 1] + vertical - hip_from_pelvis[side][:, 1] + slack)
    standing = body.ankle_height + reach - hip_local["Left"][1]
    crouch = 0.03 * running + 0.01 * np.minimum(planar, 1.5) * (1 - running)
    bounce = style.bounce * active * (0.012 * (1 - running) * step_wave - 0.035 * running * step_wave)
    pelvis_y = _soft_min(standing - crouch + bounce, *highest)
    hips = pelvis_xz + pelvis_y[:, None] * [0, 1, 0]
    return Pelvis(hips, pelvis_rot, hip_from_pelvis, twist, list_)


def legs(pelvis: Pelvis, feet: dict[str, Foot], body: Body) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Step 5: the leg joints by two-bone inverse kinematics from each hip to its ankle,
    knees pointing where the foot and pelvis point. Returns joint name -> ``(frames, 3)``
    (hips, knees, ankles, toes) and the contacts ``(frames, 2)`` (left, right in stance)."""
    joints = {}
    contacts = np.zeros((len(pelvis.hips), 2), dtype=bool)
    for n, side in enumerate(("Left", "Right")):
        foot = feet[side]
        hip = pelvis.hips + pelvis.hip_offsets[side]
        foot_forward = _apply(foot.rotation, np.array([0.0, 0.0, 1.0]))
        pole = foot_forward + _apply(pelvis.rotation, np.array([0.0, 0.0, 1.0]))
        knee, ankle = _two_bone_ik(hip, foot.ankle, pole, body.thigh, body.shin)
        joints[f"{side}UpLeg"], joints[f"{side}Leg"], joints[f"{side}Foot"] = hip, knee, ankle
        joints[f"{side}ToeBase"] = ankle + _apply(foot.rotation, body.toe_offset)
        contacts[:, n] = foot.stance
    return joints, contacts


def upper_body(root: np.ndarray, padded: np.ndarray, gait: Gait, pelvis: Pelvis,
               feet: dict[str, Foot], body: Body, style: Style) -> dict[str, np.ndarray]:
    """Step 6: spine, head and arm joints by forward kinematics, joint name -> ``(frames, 3)``.

    The spine leans into speed and turns and twists against the pelvis, the head stays
    steady, the arms swing against the legs with elbows bent more when running.
    """
    forward, _, turning = padded.T
    planar, running, active = gait.planar, gait.running, gait.active
    twist, list_, hips = pelvis.twist, pelvis.list_angle, pelvis.hips
    heading_deg = np.rad2deg(root[:, 2])
    speed_lean = (2.0 + 1.5 * np.minimum(planar, 2.0)) * (1 - running) + (5.0 + 1.5 * planar) * running
    lean = (speed_lean * np.sign(forward + 1e-9) * (forward > -0.1) + style.lean)
    turn_lean = np.rad2deg(np.arctan(forward * turning / GRAVITY)) * 0.7   # into the turn
    counter = -0.8 * twist                                       # chest twists against pelvis
    lumbar_rot = (axis_rotation("Y", heading_deg + 0.3 * twist) @ axis_rotation("X", 0.5 * lean)
                  @ axis_rotation("Z", -0.5 * turn_lean + 0.3 * list_))
    chest_rot = (axis_rotation("Y", heading_deg + counter) @ axis_rotation("X", lean)
                 @ axis_rotation("Z", -turn_lean))
    neck_rot = (axis_rotation("Y", heading_deg + 0.3 * counter) @ axis_rotation("X", 0.4 * lean)
                @ axis_rotation("Z", -0.3 * turn_lean))
    head_rot = axis_rotation("Y", heading_deg) @ axis_rotation("X", -4.0 + 0.2 * lean)
    up = np.array([0.0, 1.0, 0.0])
    spine = hips + _apply(lumbar_rot, body.lower_back * up)
    chest = spine + _apply(chest_rot, body.upper_back * up)
    neck = chest + _apply(neck_rot, body.neck * up)
    joints = {"Spine": spine, "Spine1": chest, "Neck1": neck,
              "Head": neck + _apply(head_rot, body.head * np.array([0.0, 0.97, 0.25]))}

    amplitude = active * style.arm_swing * ((1 - running) * (8.0 + 9.0 * np.minimum(planar, 2.0))
                                            + running * (28.0 + 4.0 * planar))
    elbow = 12.0 + style.elbow_bend + running * 75.0
    for side, sign, asym in (("Left", 1.0, 1 + style.asymmetry), ("Right", -1.0, 1 - style.asymmetry)):
        swing = asym * amplitude * np.cos(2 * np.pi * (feet[side].u - feet[side].beta))   # forward +
        swing *= np.sign(forward + 0.3)                      # arms follow the legs backwards too
        abduct = sign * (6.0 + 6.0 * running)
        flex = elbow + 0.4 * np.maximum(swing, 0)
        shoulder = chest + _apply(chest_rot, np.array(body.shoulder_offset) * [sign, 1, 1])
        upper_rot = (chest_rot @ axis_rotation("X", -swing)
                     @ axis_rotation("Z", np.broadcast_to(abduct, swing.shape)))
        fore_rot = upper_rot @ axis_rotation("X", -flex)
        hand_rot = fore_rot @ axis_rotation("X", np.broadcast_to(-10.0, swing.shape))
        elbow_pos = shoulder + _apply(upper_rot, -body.upper_arm * up)
        wrist = elbow_pos + _apply(fore_rot, -body.forearm * up)
        joints[f"{side}Arm"], joints[f"{side}ForeArm"], joints[f"{side}Hand"] = shoulder, elbow_pos, wrist
        joints[f"{side}HandIndex1"] = wrist + _apply(hand_rot, -body.hand * up)
    return joints


def generate(control: np.ndarray, fps: float, body: Body | None = None,
             style: Style | None = None, start: np.ndarray | None = None,
             phase: float = 0.0) -> Motion:
    """Generate the motion that follows ``control`` ``(frames, 3)`` at ``fps``.

    Args:
        control: forward (m/s), sideways (m/s, left positive), turning (rad/s, left positive).
        fps: frames per second of ``control`` and of the result.
        body, style: default :class:`Body` and :class:`Style` if not given.
        start: root ``(x, z, heading)`` at the first frame (default the origin facing +z).
        phase: where in the stride the clip starts, in strides (0-1).

    Runs the six steps of the module docstring on the control padded by a second either
    side, then cuts the padding off. Draws no random numbers.
    """
    control = np.asarray(control, dtype=np.float64)
    if control.ndim != 2 or control.shape[1] != 3 or len(control) < 2:
        raise ValueError(f"control: expected shape (frames >= 2, 3), got {control.shape}")
    if not np.isfinite(control).all():
        raise ValueError("control: contains NaN or infinite values")
    if fps <= 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    body = body or Body()
    style = style or Style()

    padded, root = root_path(control, fps, start)
    gait = gait_timing(padded, fps, style, phase)
    feet = footsteps(root, padded, gait, body, style)
    pelvis = pelvis_motion(root, gait, feet, body, style)
    leg_joints, contacts = legs(pelvis, feet, body)
    joints = {"Hips": pelvis.hips} | leg_joints | upper_body(root, padded, gait, pelvis, feet, body, style)

    positions = np.zeros((len(padded), len(J), 3))
    for name, position in joints.items():
        positions[:, J[name]] = position
    keep = slice(padding_frames(fps), len(padded) - padding_frames(fps))
    return Motion(positions[keep], control, contacts[keep], fps, body, style)
