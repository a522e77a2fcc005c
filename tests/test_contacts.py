"""Foot contacts, the foot lock (offline and causal), two-bone IK, bones put back to their
lengths, and the planted feet's world velocity (motionlab.contacts)."""
import numpy as np
import pytest
import torch

from motionlab import contacts, metrics, synthetic
from motionlab import representation as rep
from motionlab.filters import smoothstep
from motionlab.skeleton import FEET, LOCOMOTION

from conftest import cmu_files, requires_cmu, walker

FPS = 20.0
ABOVE_HIPS = [j for j in range(LOCOMOTION.n_joints) if j not in {k for leg in contacts.LEGS for k in leg[1:]}]


@pytest.fixture(scope="module")
def walking() -> np.ndarray:
    """Two built-in bodies walking the walk preset for 6 s, world positions (2, 121, 21, 3)."""
    control = synthetic.preset_control("walk", 6.0 + 1 / FPS, FPS)
    rng = np.random.default_rng(3)
    return np.stack([synthetic.generate(control, FPS, synthetic.Body.random(rng), phase=0.3 * k).positions
                     for k in range(2)])


def sliding(positions: np.ndarray, factor: float = 1.15) -> np.ndarray:
    """The same bodies carried faster than their feet sweep: the stride a model under-shoots.
    Planted feet then slide forward at (factor - 1) times the body's speed."""
    features = np.stack([rep.to_features(p, FPS) for p in positions])
    features[..., rep.N_POSE:rep.N_POSE + 2] *= factor
    return rep.to_positions(features, FPS)


def skating(positions, floor) -> float:
    return metrics.foot_skating(positions, FPS, rest_height_m=floor)


# ---------------------------------------------------------------------------------------
# contacts from data
# ---------------------------------------------------------------------------------------

def test_walking_feet_are_in_contact_about_60_percent_of_the_time(walking):
    labels = contacts.detect(walking, FPS)
    assert labels.shape == walking.shape[:2] + (4,) and labels.dtype == bool
    assert 0.45 < labels.mean() < 0.8
    # the two feet alternate: each is free somewhere, and at least one foot is down nearly always
    assert (~labels).any(axis=1).all()
    feet_down = labels.reshape(*labels.shape[:2], 2, 2).any(-1).any(-1)
    assert feet_down[:, int(FPS):].mean() > 0.9          # after the first second's ramp


def test_a_standing_body_is_in_contact_throughout_and_a_lifted_foot_is_not(walking):
    standing = np.repeat(walking[0, :1], 40, axis=0)
    assert contacts.detect(standing, FPS).all()
    lifted = standing.copy()
    left_leg = [LOCOMOTION.index(n) for n in ("LeftFoot", "LeftToeBase")]
    lifted[:, left_leg, 1] += 0.2
    labels = contacts.detect(lifted, FPS, planted_height_m=contacts.planted_heights(standing))
    assert not labels[:, :2].any() and labels[:, 2:].all()


def test_the_majority_filter_removes_one_frame_flickers(walking):
    standing = np.repeat(walking[0, :1], 40, axis=0)
    flicker = standing.copy()
    flicker[20, FEET[1], 1] += 0.2                       # one frame of a toe in the air
    floor = contacts.planted_heights(standing)
    assert contacts.detect(flicker, FPS, floor)[:, 1].all()
    assert not contacts.detect(flicker, FPS, floor, clean_s=0)[20, 1]


@pytest.mark.parametrize("fps, frames", [(20.0, 5), (30.0, 7), (60.0, 15)])
def test_the_majority_filter_spans_the_odd_number_of_frames_nearest_clean_s(walking, fps, frames):
    # contacts.CLEAN_S (0.25 s) is 5 frames at 20 fps: a gap of half of it or less is filled, one
    # frame longer is kept; the same in seconds at other frame rates
    standing = np.repeat(walking[0, :1], 80, axis=0)
    floor = contacts.planted_heights(standing)
    for gap, filled in ((frames // 2, True), (frames // 2 + 1, False)):
        lifted = standing.copy()
        lifted[40:40 + gap, FEET[1], 1] += 0.2
        assert contacts.detect(lifted, fps, floor)[40:40 + gap, 1].all() == filled, (gap, filled)


def test_horizontal_speed_is_central_differences_over_its_window(walking):
    positions = walking[0]
    xz_speed = np.linalg.norm(np.gradient(positions[..., [0, 2]], axis=0), axis=-1) * FPS
    np.testing.assert_allclose(contacts.horizontal_speed(positions, FPS, window_s=0.1), xz_speed, atol=1e-12)
    # a joint moving at 1.3 m/s reads 1.3 m/s everywhere, the cut windows at the ends included
    steady = np.zeros((30, 2, 3))
    steady[:, 1, 0] = 1.3 * np.arange(30) / FPS
    np.testing.assert_allclose(contacts.horizontal_speed(steady, FPS)[:, 1], 1.3)
    with pytest.raises(ValueError, match="window_s"):
        contacts.horizontal_speed(positions, FPS, window_s=-0.1)
    with pytest.raises(ValueError, match="speed_window_s"):
        contacts.detect(positions, FPS, speed_window_s=float("nan"))


def test_a_planted_foot_that_jitters_stays_in_contact_and_a_sliding_one_does_not(walking):
    """A sampled model's planted foot jitters from frame to frame: here a toe standing still
    but for 3.5 cm of noise in x and z every frame (five draws). Measured over the 0.2-s
    window the jitter largely cancels and the toe is planted; frame to frame (0.1 s) it is
    taken for moving a quarter of the time or more. A toe that slides steadily at 0.8 m/s is
    not planted, whatever the window."""
    standing = np.repeat(walking[0, :1], 60, axis=0)
    floor = contacts.planted_heights(standing)
    shares = {0.1: [], contacts.SPEED_WINDOW_S: []}
    for seed in range(5):
        rng = np.random.default_rng(seed)
        jitter = standing.copy()
        jitter[:, FEET[1], 0] += 0.035 * rng.normal(size=60)
        jitter[:, FEET[1], 2] += 0.035 * rng.normal(size=60)
        for window in shares:
            shares[window].append(contacts.detect(jitter, FPS, floor, speed_window_s=window)[:, 1].mean())
    assert np.mean(shares[contacts.SPEED_WINDOW_S]) > 0.95, shares
    assert np.mean(shares[0.1]) < 0.75, shares
    slide = standing.copy()
    slide[:, FEET[1], 0] += 0.8 * np.arange(60) / FPS
    for window in shares:
        assert not contacts.detect(slide, FPS, floor, speed_window_s=window)[:, 1].any()


def test_labels_of_data_features_agree_with_the_detector(walking):
    features = torch.tensor(np.stack([rep.to_features(p, FPS) for p in walking]))
    labels = contacts.contact_labels(features, FPS, contacts.planted_heights(walking)).numpy().astype(bool)
    detected = contacts.detect(walking, FPS, clean_s=0)
    agree = (labels == (detected[:, 1:] & detected[:, :-1])).mean()
    assert agree > 0.85, agree


# ---------------------------------------------------------------------------------------
# two-bone IK and bones
# ---------------------------------------------------------------------------------------

def test_two_bone_ik_reaches_keeps_lengths_and_bends_the_knee_its_way():
    rng = np.random.default_rng(0)
    hip = rng.normal(size=(50, 3))
    knee = hip + np.array([0, -0.45, 0.05]) + 0.02 * rng.normal(size=(50, 3))
    ankle = knee + np.array([0, -0.42, -0.03]) + 0.02 * rng.normal(size=(50, 3))
    target = hip + 0.85 * (ankle - hip) + 0.02 * rng.normal(size=(50, 3))
    new_knee, new_ankle, reached = contacts.two_bone_ik(hip, knee, ankle, target)
    assert reached.all()
    np.testing.assert_allclose(new_ankle, target, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(new_knee - hip, axis=-1), np.linalg.norm(knee - hip, axis=-1))
    np.testing.assert_allclose(np.linalg.norm(new_ankle - new_knee, axis=-1), np.linalg.norm(ankle - knee, axis=-1))
    # the knee stays on the side it pointed to, seen from the hip-target line
    line = (target - hip) / np.linalg.norm(target - hip, axis=-1, keepdims=True)

    def side(k):
        v = k - hip
        return v - (v * line).sum(-1, keepdims=True) * line
    assert ((side(knee) * side(new_knee)).sum(-1) > 0).all()
    far = hip + 5 * line
    _, straight, reached = contacts.two_bone_ik(hip, knee, ankle, far)
    assert not reached.any()
    leg = np.linalg.norm(knee - hip, axis=-1) + np.linalg.norm(ankle - knee, axis=-1)
    np.testing.assert_allclose(np.linalg.norm(straight - hip, axis=-1), leg, rtol=1e-5)


def test_fit_bones_gives_every_bone_one_length_and_keeps_the_feet(walking):
    rng = np.random.default_rng(1)
    stretched = walking + 0.01 * rng.normal(size=walking.shape)
    assert metrics.bone_length_drift(stretched) > 0.01
    fitted = contacts.fit_bones(stretched)
    assert metrics.bone_length_drift(fitted) < 1e-9
    lengths = LOCOMOTION.bone_lengths(fitted)
    np.testing.assert_allclose(lengths, np.median(LOCOMOTION.bone_lengths(stretched), axis=1, keepdims=True)
                               .repeat(walking.shape[1], 1), atol=1e-9)
    ankles = [FEET[0], FEET[2]]
    moved = np.linalg.norm(fitted[..., ankles, :] - stretched[..., ankles, :], axis=-1)
    legs = [[LOCOMOTION.index(s + n) for n in ("UpLeg", "Leg", "Foot")] for s in ("Left", "Right")]
    reach = np.stack([np.linalg.norm(fitted[..., a, :] - fitted[..., b, :], axis=-1)
                      + np.linalg.norm(fitted[..., b, :] - fitted[..., c, :], axis=-1) for a, b, c in legs], -1)
    hip_to_ankle = np.stack([np.linalg.norm(stretched[..., c, :] - fitted[..., a, :], axis=-1) for a, _, c in legs], -1)
    within = hip_to_ankle < reach * (1 - 1e-5)
    assert within.mean() > 0.5 and moved[within].max() < 1e-9             # where the leg reaches, the feet stay
    np.testing.assert_array_equal(fitted[..., 0, :], stretched[..., 0, :])          # the root stays
    given = contacts.fit_bones(stretched, LOCOMOTION.bone_lengths(walking[0, 0]), keep_feet=False)
    np.testing.assert_allclose(LOCOMOTION.bone_lengths(given), np.broadcast_to(LOCOMOTION.bone_lengths(
        walking[0, 0]), LOCOMOTION.bone_lengths(given).shape), atol=1e-9)


# ---------------------------------------------------------------------------------------
# the lock
# ---------------------------------------------------------------------------------------

def test_the_lock_stops_sliding_feet_and_moves_nothing_above_the_hips(walking):
    floor = contacts.planted_heights(walking)
    slides = sliding(walking)
    assert skating(slides, floor) > 3 * skating(walking, floor)          # 3-14x: the shipped models
    result = contacts.lock(slides, FPS, planted_height_m=floor)
    locked = result.positions
    assert skating(locked, floor) < 0.5 * skating(slides, floor)
    np.testing.assert_array_equal(locked[..., ABOVE_HIPS, :], slides[..., ABOVE_HIPS, :])
    # bones keep the lengths they had in every frame
    np.testing.assert_allclose(LOCOMOTION.bone_lengths(locked), LOCOMOTION.bone_lengths(slides), atol=1e-9)
    # no pops: the feet accelerate no harder than the data's and the sliding motion's allow
    assert metrics.foot_acceleration(locked, FPS) <= 1.5 * max(metrics.foot_acceleration(slides, FPS),
                                                               metrics.foot_acceleration(walking, FPS))
    # steps kept: the feet still move relative to the body
    raw_step = metrics.stepping_speed(np.stack([rep.to_features(p, FPS) for p in slides]), FPS, smooth_s=0.1)
    new_step = metrics.stepping_speed(np.stack([rep.to_features(p, FPS) for p in locked]), FPS, smooth_s=0.1)
    assert new_step.mean() >= 0.95 * raw_step.mean()
    assert 0.4 < result.locked_share < 0.8 and result.out_of_reach < 0.2


def test_a_held_foot_stays_where_it_landed(walking):
    slides = sliding(walking[:1])
    result = contacts.lock(slides, FPS)
    toe = result.positions[0, :, FEET[1]]
    held = result.contacts[0, :, 1]
    runs = np.flatnonzero(np.diff(np.r_[0, held.astype(int), 0]))
    longest = max(zip(runs[::2], runs[1::2]), key=lambda r: r[1] - r[0])
    start, end = longest[0] + 1, longest[1]              # skip the landing frame
    drift = np.linalg.norm(toe[start:end, [0, 2]] - toe[start, [0, 2]], axis=-1).max()
    assert drift < 0.01, drift


def test_a_foot_the_body_glides_away_from_is_let_go_and_stays_on_the_floor(walking):
    """A body that glides 1.5 m/s with its feet still (the LSTM-3LR's failure), every foot
    joint labelled in contact: once even a foot pivoting on its toe cannot reach the held
    toe, the lock lets go (counted), so the foot never hangs in the air on a stretched leg
    aimed at a spot metres behind."""
    frames = 60
    glide = np.repeat(walking[:1, :1], frames, axis=1)
    glide[..., 0] += 1.5 / FPS * np.arange(frames)[None, :, None]
    floor = contacts.planted_heights(walking)
    result = contacts.lock(glide, FPS, contacts=np.ones((1, frames, 4), dtype=bool), planted_height_m=floor)
    assert result.reach_releases == 2 and result.out_of_reach == 1.0               # each foot once
    hips = [leg[0] for leg in contacts.LEGS]                                     # each leg's hip joint
    behind = np.linalg.norm((result.positions[0, :, FEET] - glide[0, :, [hips[0], hips[0], hips[1], hips[1]]])
                            [..., [0, 2]], axis=-1)
    reach = sum(np.linalg.norm(glide[0, 0, a] - glide[0, 0, b]) for a, b in zip(contacts.LEGS[0], contacts.LEGS[0][1:]))
    assert behind.max() < reach + 0.05                                           # no foot left metres behind
    lifted = result.positions[0, :, FEET, 1] - glide[0, :, FEET, 1]                # (4, frames)
    assert lifted[[1, 3]].max() < 0.05 and lifted[[0, 2]].max() < 0.15      # toes on the floor, heels off it
    np.testing.assert_allclose(LOCOMOTION.bone_lengths(result.positions), LOCOMOTION.bone_lengths(glide), atol=1e-9)


def test_a_motion_without_contacts_is_left_alone(walking):
    high = walking[:1].copy()
    high[..., 1] += 0.5
    result = contacts.lock(high, FPS, planted_height_m=contacts.planted_heights(walking))
    assert not result.contacts.any()
    np.testing.assert_array_equal(result.positions, high)


def test_the_causal_lock_needs_no_future_and_equals_the_offline_one_given_the_same_contacts(walking):
    slides = sliding(walking)
    offline = contacts.lock(slides, FPS, approach_s=0.0)
    floor = contacts.planted_heights(slides)
    lock = contacts.FootLock(FPS, batch=2, planted_height_m=floor, landing=0.0)    # no landing step either
    stepped = np.stack([lock.step(slides[:, t], offline.contacts[:, t]) for t in range(slides.shape[1])], axis=1)
    np.testing.assert_allclose(stepped, offline.positions, atol=1e-12)
    # the offline lock is the causal one given the contacts and the approach, its one look-ahead
    approach = contacts.approach_shift(slides, offline.contacts, FPS, floor)
    lock.reset()
    stepped = np.stack([lock.step(slides[:, t], offline.contacts[:, t], approach[:, t])
                        for t in range(slides.shape[1])], axis=1)
    np.testing.assert_allclose(stepped, contacts.lock(slides, FPS).positions, atol=1e-12)
    # detecting on its own, frame by frame: later frames cannot change earlier outputs
    one = contacts.FootLock(FPS, planted_height_m=floor)
    first = np.stack([one.step(frame) for frame in slides[0]])
    changed = slides[0].copy()
    changed[60:] += np.array([0.3, 0.0, -0.2])
    one.reset()
    second = np.stack([one.step(frame) for frame in changed])
    np.testing.assert_array_equal(first[:60], second[:60])
    assert skating(first[None], floor) < 0.6 * skating(slides[:1], floor)


def test_the_causal_lock_adds_a_model_s_drawn_contacts_to_the_ones_it_detects(walking):
    slides = sliding(walking)
    floor = contacts.planted_heights(slides)
    lock = contacts.FootLock(FPS, batch=2, planted_height_m=floor)
    detected = []
    for t in range(slides.shape[1]):
        lock.step(slides[:, t])
        detected.append(lock.contact.copy())
    detected = np.stack(detected, 1)                                      # (2, frames, 4)
    # nothing drawn: the detector's contacts, the same motion out
    lock.reset()
    none_drawn = np.zeros(4 * 2, dtype=bool).reshape(2, 4)
    plain = contacts.FootLock(FPS, batch=2, planted_height_m=floor)
    for t in range(slides.shape[1]):
        np.testing.assert_array_equal(lock.step(slides[:, t], drawn=none_drawn), plain.step(slides[:, t]))
    # a drawn contact holds a foot the detector lets go: every frame of the left toe drawn down
    lock.reset()
    toe = np.zeros((2, 4), dtype=bool)
    toe[:, 1] = True
    held = []
    for t in range(slides.shape[1]):
        lock.step(slides[:, t], drawn=toe)
        held.append(lock.contact.copy())
    held = np.stack(held, 1)
    assert held[..., 1].all() and (held[..., [0, 2, 3]] == detected[..., [0, 2, 3]]).all()
    with pytest.raises(ValueError, match="drawn: expected booleans"):
        lock.step(slides[:, 0], drawn=np.ones((2, 3), dtype=bool))
    with pytest.raises(ValueError, match="drawn: give the contacts"):
        lock.step(slides[:, 0], contacts=toe, drawn=toe)


def test_the_offline_lock_and_finish_hold_a_model_s_drawn_contacts_too(walking):
    slides = sliding(walking)
    floor = contacts.planted_heights(slides)
    drawn = np.zeros(slides.shape[:2] + (4,), dtype=bool)
    drawn[:, 20:40, 3] = True                                            # the right toe drawn down for 1 s
    detected = contacts.detect(slides, FPS, floor)
    given = contacts.lock(slides, FPS, planted_height_m=floor, drawn=drawn)
    np.testing.assert_array_equal(given.contacts, detected | drawn)
    np.testing.assert_allclose(given.positions,
                               contacts.lock(slides, FPS, detected | drawn, planted_height_m=floor).positions)
    features = np.stack([rep.to_features(p, FPS) for p in slides])
    done = contacts.finish(features, FPS, planted_height_m=floor, drawn=drawn)
    assert done.lock.contacts[:, 20:40, 3].all()
    with pytest.raises(ValueError, match="drawn: expected booleans"):
        contacts.lock(slides, FPS, drawn=drawn[..., :3])
    with pytest.raises(ValueError, match="drawn: give the contacts"):
        contacts.lock(slides, FPS, contacts=detected, drawn=drawn)


def test_the_causal_lock_guesses_where_a_low_foot_coming_down_lands():
    """FootLock's landing step from two frames: an ankle 3 cm above its planted height that
    came down 1.5 cm lands in 2 frames, within APPROACH_S at 20 fps; it is drawn ahead along
    its last horizontal step by LANDING_GUESS x 2 steps, weighted by how soon and how low."""
    floor, ankle = np.asarray(contacts.PLANTED_HEIGHT_M), FEET[0]
    before = walker(frames=1)[0]
    before[FEET, 1] = floor + 0.5                                           # every foot joint high: no guess
    before[ankle, 1] = floor[0] + 0.045
    now = before.copy()
    now[ankle] += [0.04, -0.015, 0.02]                       # came down 1.5 cm, stepped (4, 2) cm: too fast to hold
    lock = contacts.FootLock(FPS, planted_height_m=floor)
    assert not lock.landing_guess(before[None]).any()                       # no last frame yet
    lock.step(before)
    guess = lock.landing_guess(now[None])[0]
    n, steps = 2.0, contacts.APPROACH_S * FPS
    weight = smoothstep(1 - n / (steps + 1)) * (1 - smoothstep(
        0.03 / (contacts.APPROACH_HEIGHT * contacts.CONTACT_HEIGHT_M[0])))
    np.testing.assert_allclose(guess[0], contacts.LANDING_GUESS * weight * n * np.array([0.04, 0.02]))
    assert 0 < weight < 1 and not guess[1:].any()                           # the high joints: nothing
    rising = now.copy()
    rising[ankle, 1] = floor[0] + 0.05                                      # going up: it does not land
    assert not lock.landing_guess(rising[None]).any()
    off = contacts.FootLock(FPS, planted_height_m=floor, landing=0.0)
    off.step(before)
    assert not off.landing_guess(now[None]).any()
    out = lock.step(now)                                                    # step() applies it to the free foot
    assert not lock.locked.any() and np.isfinite(out).all()
    np.testing.assert_allclose(lock.approach[0], guess)


def test_a_landing_foot_is_slowed_into_its_spot_only_while_low(walking):
    slides = sliding(walking, 1.4)
    floor = contacts.planted_heights(walking)
    labels = contacts.detect(slides, FPS, floor)
    shift = contacts.approach_shift(slides, labels, FPS, floor)
    assert shift.shape == labels.shape + (2,)
    # nothing in contact, nothing high, nothing long before a landing is moved
    steps = int(np.ceil(contacts.APPROACH_S * FPS))
    before = np.zeros_like(labels)
    for k in range(1, steps + 1):
        before[:, :-k] |= labels[:, k:] & ~labels[:, k - 1:-1] if k > 1 else labels[:, 1:] & ~labels[:, :-1]
    moved = np.abs(shift).sum(-1) > 0
    assert moved.any() and not (moved & labels).any()
    height = slides[..., FEET, 1] - floor
    assert not (moved & (height > contacts.APPROACH_HEIGHT * np.asarray(contacts.CONTACT_HEIGHT_M))).any()
    assert not (moved & ~before).any()
    # the low frames before a landing slide less; the landing spots and the held feet do not change
    plain, drawn = (contacts.lock(slides, FPS, labels, floor, approach_s=a).positions for a in (0.0, contacts.APPROACH_S))
    low = before & (height < contacts.APPROACH_HEIGHT * np.asarray(contacts.CONTACT_HEIGHT_M))
    speed = [np.linalg.norm(np.diff(p[..., FEET, :][..., [0, 2]], axis=1), axis=-1) for p in (plain, drawn)]
    last = low[:, :-1] & labels[:, 1:]                                     # the step onto the floor
    assert speed[1][last].mean() < 0.7 * speed[0][last].mean()
    feet_down = labels.reshape(*labels.shape[:2], 2, 2).all(-1)            # both joints of a foot held
    for leg in range(2):
        joints = list(contacts.LEGS[leg][1:])
        np.testing.assert_allclose(drawn[feet_down[..., leg]][:, joints], plain[feet_down[..., leg]][:, joints],
                                   atol=1e-12)
    np.testing.assert_array_equal(drawn[..., ABOVE_HIPS, :], slides[..., ABOVE_HIPS, :])


def test_finish_returns_features_on_the_same_path(walking):
    features = np.stack([rep.to_features(p, FPS) for p in sliding(walking)])
    done = contacts.finish(features, FPS)
    np.testing.assert_array_equal(done.features[..., rep.N_POSE:], features[..., rep.N_POSE:])
    np.testing.assert_allclose(rep.to_positions(done.features, FPS), done.positions, atol=1e-9)
    assert metrics.bone_length_drift(done.positions) < 1e-9
    raw = contacts.finish(features, FPS, fit=False, lock_feet=False)
    np.testing.assert_allclose(raw.features, features, atol=1e-9)


def test_finish_puts_a_growing_shin_back_to_the_datas_length(walking):
    # a sample whose shins lengthen as it goes (an anchored flow's feet drifting away): its
    # own median is too long; given the data's body, the finished legs have the data's bones
    body = contacts.body_lengths(walking)
    assert body.shape == (len(LOCOMOTION.bones),) and (body > 0).all()
    grown = walking.copy()
    frames = walking.shape[1]
    for knee, ankle, toe in ((LOCOMOTION.index(s + "Leg"), LOCOMOTION.index(s + "Foot"),
                              LOCOMOTION.index(s + "ToeBase")) for s in ("Left", "Right")):
        stretch = (0.3 * np.arange(frames) / frames)[None, :, None] * (walking[..., ankle, :] - walking[..., knee, :])
        grown[..., ankle, :] += stretch
        grown[..., toe, :] += stretch
    features = np.stack([rep.to_features(p, FPS) for p in grown])
    shins = [LOCOMOTION.bones.index((LOCOMOTION.index(s + "Leg"), LOCOMOTION.index(s + "Foot"))) for s in ("Left", "Right")]
    own = LOCOMOTION.bone_lengths(contacts.finish(features, FPS, lock_feet=False).positions)[..., shins]
    fitted = LOCOMOTION.bone_lengths(contacts.finish(features, FPS, bone_lengths=body, lock_feet=False).positions)
    assert (own / body[shins]).mean() > 1.1                                  # its own median: too long
    np.testing.assert_allclose(fitted, np.broadcast_to(body, fitted.shape), atol=1e-9)
    with pytest.raises(ValueError, match="lengths"):
        contacts.finish(features, FPS, bone_lengths=np.ones(3))


# ---------------------------------------------------------------------------------------
# the training term
# ---------------------------------------------------------------------------------------

def test_foot_velocity_is_the_world_velocity_of_the_feet(walking):
    features = np.stack([rep.to_features(p, FPS) for p in sliding(walking)])
    world = rep.to_positions(features, FPS)[..., FEET, :][..., [0, 2]]
    expected = np.linalg.norm(np.diff(world, axis=-3), axis=-1) * FPS
    tensor = torch.tensor(features, requires_grad=True)
    velocity = contacts.foot_velocity(tensor, FPS)
    np.testing.assert_allclose(velocity.detach().norm(dim=-1).numpy(), expected, atol=1e-9)
    velocity.square().sum().backward()
    assert tensor.grad[..., rep.N_POSE:].abs().sum() > 0 and tensor.grad[..., :rep.N_POSE].abs().sum() > 0


# ---------------------------------------------------------------------------------------
# the measures beside it
# ---------------------------------------------------------------------------------------

def test_skating_ratio_and_foot_acceleration(walking):
    standing = np.repeat(walking[0, :1], 40, axis=0)
    assert metrics.skating_ratio(standing, FPS) == 0.0
    assert metrics.foot_acceleration(standing, FPS) == 0.0
    floor = metrics.foot_rest_heights(walking)
    assert metrics.skating_ratio(sliding(walking, 2.0), FPS, floor) > metrics.skating_ratio(walking, FPS, floor)
    glide = standing + np.arange(40)[:, None, None] * np.array([0.0, 0.0, 1.0 / FPS])     # 1 m/s, feet down
    assert metrics.skating_ratio(glide, FPS) == 1.0


# ---------------------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("call, name", [
    (lambda w: contacts.lock_feet(np.where(np.arange(21)[:, None] == 3, np.nan, w[0]), FPS), "positions"),
    (lambda w: contacts.lock_feet(w[0, :, :20], FPS), "positions"),
    (lambda w: contacts.lock_feet(w[0, :2], FPS), "positions"),                   # shorter than the blend
    (lambda w: contacts.lock_feet(w[0], FPS, contacts=np.ones((w.shape[1], 2), bool)), "contacts"),
    (lambda w: contacts.lock_feet(w[0], FPS, contacts=np.ones((w.shape[1], 4))), "contacts"),
    (lambda w: contacts.lock_feet(w[0], 0.0), "fps"),
    (lambda w: contacts.approach_shift(w[0, :, :20], np.zeros((w.shape[1], 4), bool), FPS, 0.0), "positions"),
    (lambda w: contacts.approach_shift(w[0], np.zeros((w.shape[1], 2), bool), FPS, 0.0), "contacts"),
    (lambda w: contacts.approach_shift(w[0], np.zeros((w.shape[1], 4), bool), FPS, (0.0, 0.0)), "planted_height_m"),
    (lambda w: contacts.approach_shift(w[0], np.zeros((w.shape[1], 4), bool), FPS, 0.0, -1.0), "approach_s"),
    (lambda w: contacts.detect(w[0], FPS, height_m=(0.05, -1, 0.05, 0.03)), "height_m"),
    (lambda w: contacts.detect(w[0], FPS, planted_height_m=(0.1, 0.1)), "planted_height_m"),
    (lambda w: contacts.detect(w[0], FPS, speed_ms=float("nan")), "speed_ms"),
    (lambda w: contacts.fit_bones(w[0], lengths=np.ones(3)), "lengths"),
    (lambda w: contacts.FootLock(FPS, batch=2).step(w[0, 0]), "frame"),
    (lambda w: contacts.FootLock(FPS).step(w[0, 0], contacts=np.ones(3, bool)), "contacts"),
    (lambda w: contacts.FootLock(FPS, landing=-0.1), "landing"),
    (lambda w: contacts.FootLock(FPS, landing=float("nan")), "landing"),
    (lambda w: contacts.foot_velocity(np.zeros((4, 66)), FPS), "features"),
    (lambda w: metrics.skating_ratio(w[0, :1], FPS), "positions"),
    (lambda w: metrics.foot_acceleration(w[0], FPS, percentile=120), "percentile"),
])
def test_bad_input_is_refused_naming_the_argument(walking, call, name):
    with pytest.raises(ValueError, match=name):
        call(walking)


@requires_cmu
def test_real_capture_is_labelled_and_locked_without_harm():
    from motionlab import data
    clips = data.load([str(p) for p in cmu_files()[:6]], fps=FPS)
    for clip in clips:
        labels = contacts.detect(clip.positions, FPS)
        assert 0.15 < labels.mean() < 0.9, (clip.name, labels.mean())      # a runner's feet: about a quarter
        locked = contacts.lock(clip.positions, FPS)
        assert skating(locked.positions, None) <= 1.1 * skating(clip.positions, None), clip.name
        assert locked.out_of_reach < 0.1
