"""The procedural locomotion generator: determinism, physics-like plausibility, control."""
import numpy as np
import pytest

from motionlab import data, metrics, representation as rep, synthetic as syn
from motionlab.skeleton import LOCOMOTION

from conftest import CMU_DIR, cmu_files


def steady(control, seconds=12.0, fps=20.0, seed=0):
    rng = np.random.default_rng(seed)
    frames = int(seconds * fps)
    return syn.generate(np.tile(control, (frames, 1)), fps, syn.Body.random(rng), syn.Style.random(rng))


def steps_per_second(motion):
    """Heel strikes per second of both feet, counted over the clip."""
    strikes = (np.diff(motion.contacts.astype(int), axis=0) == 1).sum()
    first, last = np.flatnonzero(np.diff(motion.contacts.astype(int), axis=0).max(1) == 1)[[0, -1]]
    return (strikes - 1) / ((last - first) / motion.fps)


def test_deterministic_given_a_seed():
    a, b = syn.random_motion(6, 20, seed=5), syn.random_motion(6, 20, seed=5)
    assert np.array_equal(a.positions, b.positions) and a.body == b.body and a.style == b.style
    assert not np.allclose(syn.random_motion(6, 20, seed=6).positions[:5], a.positions[:5])
    clips = data.load("synthetic", fps=20, n_clips=3, duration_s=4, seed=2)
    again = data.load("synthetic", fps=20, n_clips=3, duration_s=4, seed=2)
    assert [c.name for c in clips] == ["synthetic_002", "synthetic_003", "synthetic_004"]
    assert all(np.array_equal(x.positions, y.positions) for x, y in zip(clips, again))
    assert clips[0].positions.shape == (80, 21, 3) and clips[0].source == "synthetic"


@pytest.mark.parametrize("seed", range(6))
def test_constant_bone_lengths_and_human_proportions(seed):
    motion = syn.random_motion(10, 30, seed=seed)
    assert np.isfinite(motion.positions).all()
    assert metrics.bone_length_drift(motion.positions) < 1e-9
    standing_height = motion.positions[:, LOCOMOTION.index("Head"), 1].max()
    assert 1.25 < standing_height < 1.7              # the head joint: CMU subjects have 1.3-1.5 m
    assert motion.positions[..., 1].min() > -1e-9    # nothing goes through the floor


def test_bodies_and_styles_vary_per_clip():
    bodies = [syn.random_motion(2, 20, seed=s).body for s in range(20)]
    legs = np.array([b.leg_length for b in bodies])
    assert legs.std() > 0.02 and 0.7 < legs.min() and legs.max() < 1.0
    styles = [syn.random_motion(2, 20, seed=s).style for s in range(20)]
    assert len({round(s.arm_swing, 6) for s in styles}) == 20


@pytest.mark.parametrize("command", [
    (1.3, 0.0, 0.0), (1.3, 0.0, 0.8), (0.6, 0.0, -0.4), (2.6, 0.0, -0.5), (3.6, 0.0, 0.3),
    (-0.8, 0.0, 0.0), (0.1, 0.45, 0.0), (0.0, -0.4, 0.0), (0.0, 0.0, 1.0)])
def test_the_representation_recovers_the_commanded_control(command):
    motion = steady(command)
    recovered = rep.to_features(motion.positions, motion.fps)[40:-40, rep.CONTROL].mean(axis=0)
    scale = max(np.abs(command[:2]).max(), 0.5)
    assert abs(recovered[0] - command[0]) <= 0.05 * scale
    assert abs(recovered[1] - command[1]) <= 0.05 * scale
    assert abs(recovered[2] - command[2]) <= 0.05 * max(abs(command[2]), 0.5)


@pytest.mark.parametrize("speed", [0.9, 1.3, 1.7])
def test_walking_cadence_and_double_support(speed):
    motion = steady((speed, 0.0, 0.0), seconds=16)
    assert 1.6 <= steps_per_second(motion) <= 2.0
    both = motion.contacts.all(axis=1)[40:]
    assert both.any() and motion.contacts[40:].any(axis=1).all()   # double support, no flight


@pytest.mark.parametrize("speed", [3.0, 4.0])
def test_running_is_faster_with_a_flight_phase(speed):
    motion = steady((speed, 0.0, 0.0), seconds=16)
    assert 2.5 <= steps_per_second(motion) <= 3.2
    airborne = ~motion.contacts.any(axis=1)[40:]
    assert airborne.mean() > 0.1 and not motion.contacts.all(axis=1)[40:].any()


def test_walk_and_run_differ_in_posture_and_arms():
    def elbow_angle(m):
        pos = m.positions
        upper = pos[:, LOCOMOTION.index("LeftArm")] - pos[:, LOCOMOTION.index("LeftForeArm")]
        lower = pos[:, LOCOMOTION.index("LeftHand")] - pos[:, LOCOMOTION.index("LeftForeArm")]
        cos = (upper * lower).sum(-1) / np.linalg.norm(upper, axis=-1) / np.linalg.norm(lower, axis=-1)
        return np.rad2deg(np.arccos(cos)).mean()

    def lean(m):
        f = rep.to_features(m.positions, m.fps)[:, rep.POSE].reshape(-1, 21, 3)
        trunk = f[:, LOCOMOTION.index("Neck1")] - f[:, 0]
        return np.rad2deg(np.arctan2(trunk[:, 2], trunk[:, 1])).mean()

    walk, run = steady((1.3, 0, 0)), steady((3.8, 0, 0))
    assert elbow_angle(run) < elbow_angle(walk) - 40          # elbows bent when running
    assert lean(run) > lean(walk) + 2                          # trunk leans forward more


def test_arms_swing_against_the_legs():
    motion = steady((1.4, 0, 0))
    f = rep.to_features(motion.positions, motion.fps)[:, rep.POSE].reshape(-1, 21, 3)
    left_hand_z = f[:, LOCOMOTION.index("LeftHand"), 2]
    left_foot_z = f[:, LOCOMOTION.index("LeftFoot"), 2]
    right_foot_z = f[:, LOCOMOTION.index("RightFoot"), 2]
    assert np.corrcoef(left_hand_z, left_foot_z - right_foot_z)[0, 1] < -0.5


def test_standing_still_is_still():
    motion = syn.generate(np.zeros((100, 3)), 20.0)
    assert np.abs(np.diff(motion.positions, axis=0)).max() < 1e-9


def test_foot_skating_no_worse_than_real_motion_capture():
    if cmu_files():
        real = np.median([metrics.foot_skating(c.positions, 20) for c in data.load(CMU_DIR, fps=20)])
        assert 100 * real == pytest.approx(metrics.CMU_REFERENCE["foot skating (cm/s)"], abs=0.01)
    else:
        real = metrics.CMU_REFERENCE["foot skating (cm/s)"] / 100
    ours = np.median([metrics.foot_skating(syn.random_motion(12, 20, seed=s).positions, 20)
                      for s in range(16)])
    assert ours <= real


def test_recorded_reference_matches_the_real_clips():
    if not cmu_files():
        pytest.skip(f"real CMU clips not found in {CMU_DIR}")
    clips = data.load(CMU_DIR, fps=20)
    drift = np.median([metrics.bone_length_drift(c.positions) for c in clips])
    assert 100 * drift == pytest.approx(metrics.CMU_REFERENCE["bone-length drift (%)"], abs=0.001)


def test_random_control_covers_the_activities():
    control = syn.random_control(600, 20, rng=1)
    forward, sideways, turning = control.T
    assert forward.max() > 3.0 and forward.min() < -0.4          # running and walking backwards
    assert np.abs(sideways).max() > 0.25 and np.abs(turning).max() > 0.6
    assert (np.abs(control).max(axis=1) < 0.02).mean() > 0.02    # some standing
    assert np.abs(np.diff(forward)).max() * 20 < 6.0              # no jumps: at most 6 m/s^2


def test_bad_arguments_are_value_errors():
    with pytest.raises(ValueError, match=r"control: expected shape \(frames >= 2, 3\)"):
        syn.generate(np.zeros((10, 2)), 20)
    with pytest.raises(ValueError, match="NaN"):
        syn.generate(np.full((10, 3), np.nan), 20)
    with pytest.raises(ValueError, match="fps"):
        syn.generate(np.zeros((10, 3)), 0)
    with pytest.raises(ValueError, match="duration_s"):
        syn.random_control(0, 20)
    with pytest.raises(ValueError, match="n_clips"):
        syn.dataset(0)


def test_preset_controls_start_from_standing_and_reach_their_targets():
    import numpy as np
    from motionlab import synthetic
    targets = {"stand still": [0, 0, 0], "walk": [1.3, 0, 0], "run": [3.2, 0, 0], "circle": [1.2, 0, 0.6],
               "side-step": [0, 0.5, 0], "backwards": [-0.8, 0, 0], "walk, then stop": [0, 0, 0]}
    assert set(targets) == set(synthetic.PRESETS)
    for name, target in targets.items():
        control = synthetic.preset_control(name, duration_s=6.0, fps=20.0)
        assert control.shape == (120, 3)
        assert np.allclose(control[0], 0.0), name
        assert np.allclose(control[-1], target), name
    stop = synthetic.preset_control("walk, then stop", 6.0, 20.0)
    assert stop[:, 0].max() > 1.2 and np.allclose(stop[-10:], 0.0)
    with pytest.raises(ValueError, match="name"):
        synthetic.preset_control("moonwalk")
    with pytest.raises(ValueError, match="duration_s"):
        synthetic.preset_control("walk", duration_s=0)


def test_walked_control_follows_the_path_with_the_stride_sway():
    from motionlab import synthetic
    drawn = synthetic.preset_control("walk", 6.0, 20.0)
    walked = synthetic.walked_control(drawn, 20.0)
    assert walked.shape == drawn.shape
    steady = slice(40, 120)
    assert abs(walked[steady, 0].mean() - 1.3) < 0.05               # the same speed on average
    assert walked[steady, 1].std() > 0.05                           # hips sway sideways with each step
    assert drawn[steady, 1].std() == 0.0


# --------------------------------------------------------------------------- the six steps

FPS, PAD = 30.0, syn.padding_frames(30.0)


@pytest.fixture(scope="module")
def steps():
    """Every step's output for one random clip, and the arguments that made them."""
    rng = np.random.default_rng(3)
    control = syn.random_control(6.0, FPS, rng)
    body, style = syn.Body.random(rng), syn.Style.random(rng)
    start, phase = np.array([1.0, -2.0, 0.4]), 0.3
    padded, root = syn.root_path(control, FPS, start)
    gait = syn.gait_timing(padded, FPS, style, phase)
    feet = syn.footsteps(root, padded, gait, body, style)
    pelvis = syn.pelvis_motion(root, gait, feet, body, style)
    leg_joints, contacts = syn.legs(pelvis, feet, body)
    upper = syn.upper_body(root, padded, gait, pelvis, feet, body, style)
    return dict(control=control, body=body, style=style, start=start, phase=phase, padded=padded,
                root=root, gait=gait, feet=feet, pelvis=pelvis, legs=leg_joints, contacts=contacts,
                upper=upper, frames=len(control) + 2 * PAD)


def test_step_1_root_path_pads_the_control_and_starts_at_start(steps):
    padded, root, frames = steps["padded"], steps["root"], steps["frames"]
    assert padded.shape == root.shape == (frames, 3)
    assert np.array_equal(padded[PAD:-PAD], steps["control"])
    assert np.array_equal(padded[:PAD], np.tile(steps["control"][0], (PAD, 1)))
    assert np.allclose(root[PAD], steps["start"])
    assert syn.padding_frames(20.0) == 20 and syn.padding_frames(29.97) == 30


def test_step_2_gait_timing(steps):
    gait, frames = steps["gait"], steps["frames"]
    for name, values in vars(gait).items():
        assert values.shape == (frames,), name
    assert gait.cycles[0] == steps["phase"] and np.all(np.diff(gait.cycles) > 0)
    for blend in (gait.active, gait.running, gait.forwardness):
        assert blend.min() >= -1e-12 and blend.max() <= 1 + 1e-12
    assert 0.3 < gait.stance_fraction.min() and gait.stance_fraction.max() < 0.7
    assert np.allclose(gait.t, np.arange(frames) / FPS)


def test_step_3_footsteps(steps):
    feet, frames, body = steps["feet"], steps["frames"], steps["body"]
    assert set(feet) == {"Left", "Right"}
    for foot in feet.values():
        assert foot.stance.shape == foot.u.shape == foot.beta.shape == foot.swing_u.shape == (frames,)
        assert foot.ankle.shape == (frames, 3) and foot.rotation.shape == (frames, 3, 3)
        assert np.array_equal(foot.stance, foot.u < foot.beta)
        assert np.all(foot.swing_u[foot.stance] == 0)
        assert foot.ankle[:, 1].min() > body.ankle_height - 1e-9           # never below the floor
        assert np.allclose(foot.rotation @ np.swapaxes(foot.rotation, -1, -2), np.eye(3))
    # the right foot is half a stride behind the left
    assert np.allclose((feet["Right"].u - feet["Left"].u) % 1.0, 0.5)


def test_step_4_pelvis(steps):
    pelvis, frames, body = steps["pelvis"], steps["frames"], steps["body"]
    assert pelvis.hips.shape == (frames, 3) and pelvis.rotation.shape == (frames, 3, 3)
    assert pelvis.twist.shape == pelvis.list_angle.shape == (frames,)
    for offset in pelvis.hip_offsets.values():
        assert np.allclose(np.linalg.norm(offset, axis=-1), np.linalg.norm(body.hip_offset))
    assert np.allclose(pelvis.hips[:, [0, 2]], steps["root"][:, :2], atol=0.05)   # sway only


def test_step_5_legs_keep_their_bone_lengths(steps):
    joints, contacts, body = steps["legs"], steps["contacts"], steps["body"]
    assert contacts.shape == (steps["frames"], 2)
    assert np.array_equal(contacts, np.stack([steps["feet"][s].stance for s in ("Left", "Right")], -1))
    for side in ("Left", "Right"):
        assert np.allclose(joints[f"{side}UpLeg"], steps["pelvis"].hips + steps["pelvis"].hip_offsets[side])
        thigh = np.linalg.norm(joints[f"{side}Leg"] - joints[f"{side}UpLeg"], axis=-1)
        shin = np.linalg.norm(joints[f"{side}Foot"] - joints[f"{side}Leg"], axis=-1)
        assert np.allclose(thigh, body.thigh) and np.allclose(shin, body.shin)


def test_step_6_upper_body_gives_the_remaining_joints(steps):
    upper, frames = steps["upper"], steps["frames"]
    assert set(upper) | set(steps["legs"]) | {"Hips"} == set(LOCOMOTION.names)
    assert not set(upper) & set(steps["legs"])
    assert all(position.shape == (frames, 3) for position in upper.values())
    upper_arm = np.linalg.norm(upper["LeftForeArm"] - upper["LeftArm"], axis=-1)
    assert np.allclose(upper_arm, steps["body"].upper_arm)


def test_generate_is_the_six_steps_composed(steps):
    motion = syn.generate(steps["control"], FPS, steps["body"], steps["style"], steps["start"], steps["phase"])
    joints = {"Hips": steps["pelvis"].hips} | steps["legs"] | steps["upper"]
    for name, position in joints.items():
        assert np.array_equal(motion.positions[:, LOCOMOTION.index(name)], position[PAD:-PAD]), name
    assert np.array_equal(motion.contacts, steps["contacts"][PAD:-PAD])
    assert np.array_equal(motion.control, steps["control"])
