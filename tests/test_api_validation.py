"""Bad arguments to the public API fail at once with a ``ValueError`` that names them.

One case per (function, bad input): a wrong-shaped, empty or non-finite array, or a bad
number (a frame rate of NaN, inf, 0, -20 or 1e12 fps, ...). The command line reports bad
options as a usage error (exit code 2) naming the option.
"""
import dataclasses
import math

import matplotlib.pyplot as plt
import numpy as np
import pytest
import torch

from motionlab import data, filters, metrics, training, viz
from motionlab import representation as rep
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder
from motionlab.models.dfn import DFNConfig
from motionlab.models.moglow import MoGlowConfig
from motionlab.models.vae import VAEConfig

from conftest import walker

WALK = walker(frames=40)                                  # (40, 21, 3) metres
FEATURES = rep.to_features(WALK, 20.0)                    # (40, 66)
WINDOWS = np.stack([FEATURES, FEATURES])                  # (2, 40, 66)
NAN_FEATURES = np.where(np.arange(66) == 5, np.nan, FEATURES)
SAMPLES = np.stack([WALK, WALK + 0.1])                    # (2, 40, 21, 3)
SIGNAL = np.linspace(0, 1, 50)[:, None] * [1.0, 2.0]     # (50, 2)
AE = ConvAutoencoder(ConvAEConfig(window=16, filters=8, width=5))
GOOD_X = torch.zeros(2, 16, 66)


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _animation():
    return viz.animate(WALK[:2], 20)


BAD_RATES = [math.nan, math.inf, -math.inf, 0, -20.0, 1e12, "20", None, True]

# every public function that takes a frame rate: (name, call with that rate, argument name)
RATE_CALLS = [
    ("to_features", lambda fps: rep.to_features(WALK, fps), "fps"),
    ("to_positions", lambda fps: rep.to_positions(FEATURES, fps), "fps"),
    ("to_positions batch", lambda fps: rep.to_positions(WINDOWS, fps), "fps"),
    ("integrate_control", lambda fps: rep.integrate_control(FEATURES[:, rep.CONTROL], fps), "fps"),
    ("facing_angles", lambda fps: rep.facing_angles(WALK, fps), "fps"),
    ("root_trajectory", lambda fps: rep.root_trajectory(WALK, fps), "fps"),
    ("root_start", lambda fps: rep.root_start(WALK, fps), "fps"),
    ("reverse_features", lambda fps: rep.reverse_features(FEATURES, fps), "fps"),
    ("foot_skating", lambda fps: metrics.foot_skating(WALK, fps), "fps"),
    ("window_errors", lambda fps: metrics.window_errors(WINDOWS, WINDOWS, fps), "fps"),
    ("control_drift", lambda fps: metrics.control_drift(WINDOWS, WINDOWS, fps), "fps"),
    ("stepping_speed", lambda fps: metrics.stepping_speed(FEATURES, fps), "fps"),
    ("stepping_speed smoothed", lambda fps: metrics.stepping_speed(FEATURES, fps, smooth_s=0.1), "fps"),
    ("errors_by_frame", lambda fps: metrics.errors_by_frame(WINDOWS, WINDOWS, fps), "fps"),
    ("summarize", lambda fps: metrics.summarize(WALK, fps), "fps"),
    ("frame_speed", lambda fps: metrics.frame_speed(WINDOWS, fps), "fps"),
    ("animate", lambda fps: viz.animate(WALK, fps), "fps"),
    ("plot_trajectory", lambda fps: viz.plot_trajectory(WALK, fps), "fps"),
    ("plot_controls", lambda fps: viz.plot_controls(FEATURES, fps), "fps"),
    ("plot_frame", lambda fps: viz.plot_frame(WALK, 3, fps), "fps"),
    ("plot_motion", lambda fps: viz.plot_motion(FEATURES, fps), "fps"),
    ("plot_conv_filters", lambda fps: viz.plot_conv_filters(AE.encoder.weight, rep.FEATURE_NAMES, fps=fps), "fps"),
    ("save_gif", lambda fps: viz.save_gif(_animation(), "never-written.gif", fps=fps), "fps"),
    ("lowpass", lambda fps: filters.lowpass(SIGNAL, 2.0, fps), "fps"),
    ("resample fps_in", lambda fps: filters.resample(SIGNAL, fps, 20), "fps_in"),
    ("resample fps_out", lambda fps: filters.resample(SIGNAL, 120, fps), "fps_out"),
]


OPTIONAL_RATE = {"plot_conv_filters", "save_gif"}       # fps=None is their default


@pytest.mark.parametrize("call, name, fps", [
    pytest.param(call, name, fps, id=f"{label}-{fps!r}")
    for label, call, name in RATE_CALLS for fps in BAD_RATES if not (fps is None and label in OPTIONAL_RATE)])
def test_bad_frame_rates_are_named(call, name, fps):
    with pytest.raises(ValueError, match=rf"^{name}: "):
        call(fps)


NAN = math.nan

# (function and bad input, call, the argument the message must name)
BAD_CALLS = {
    # representation
    "to_features empty list": (lambda: rep.to_features([], 20), "positions"),
    "to_features no frames": (lambda: rep.to_features(np.zeros((0, 21, 3)), 20), "positions"),
    "to_features 20 joints": (lambda: rep.to_features(WALK[:, :20], 20), "positions"),
    "to_features inf": (lambda: rep.to_features(WALK + np.inf, 20), "positions"),
    "to_features smoothing nan": (lambda: rep.to_features(WALK, 20, facing_smoothing_s=NAN), "facing_smoothing_s"),
    "facing_angles smoothing < 0": (lambda: rep.facing_angles(WALK, 20, facing_smoothing_s=-1), "facing_smoothing_s"),
    "to_positions empty list": (lambda: rep.to_positions([], 20), "features"),
    "to_positions 65 columns": (lambda: rep.to_positions(FEATURES[:, :65], 20), "features"),
    "to_positions batch 65 columns": (lambda: rep.to_positions(WINDOWS[..., :65], 20), "features"),
    "to_positions nan": (lambda: rep.to_positions(NAN_FEATURES, 20), "features"),
    "to_positions start nan": (lambda: rep.to_positions(FEATURES, 20, start=[0, NAN, 0]), "start"),
    "integrate_control 2 columns": (lambda: rep.integrate_control(np.zeros((5, 2)), 20), "control"),
    "integrate_control empty": (lambda: rep.integrate_control(np.zeros((0, 3)), 20), "control"),
    "integrate_control start shape": (lambda: rep.integrate_control(np.zeros((5, 3)), 20, start=[0, 0]), "start"),
    "mirror_features 65 columns": (lambda: rep.mirror_features(FEATURES[:, :65]), "features"),
    "mirror_features empty": (lambda: rep.mirror_features(np.zeros((0, 66))), "features"),
    "mirror_features nan": (lambda: rep.mirror_features(NAN_FEATURES), "features"),
    "reverse_features 65 columns": (lambda: rep.reverse_features(FEATURES[:, :65], 20), "features"),
    "reverse_features batch": (lambda: rep.reverse_features(WINDOWS, 20), "features"),
    "reverse_features empty": (lambda: rep.reverse_features([], 20), "features"),
    "reverse_features nan": (lambda: rep.reverse_features(NAN_FEATURES, 20), "features"),
    # metrics
    "pose_error joint 100": (lambda: metrics.pose_error(FEATURES, FEATURES, joints=[100]), "joints"),
    "pose_error joint 21": (lambda: metrics.pose_error(FEATURES, FEATURES, joints=[0, 21]), "joints"),
    "pose_error joint -1": (lambda: metrics.pose_error(FEATURES, FEATURES, joints=[-1]), "joints"),
    "pose_error joint 1.5": (lambda: metrics.pose_error(FEATURES, FEATURES, joints=[1.5]), "joints"),
    "pose_error no joints": (lambda: metrics.pose_error(FEATURES, FEATURES, joints=[]), "joints"),
    "pose_error joints not a list": (lambda: metrics.pose_error(FEATURES, FEATURES, joints=3), "joints"),
    "pose_error 65 columns": (lambda: metrics.pose_error(FEATURES[:, :65], FEATURES), "pred_features"),
    "pose_error mismatched": (lambda: metrics.pose_error(FEATURES, FEATURES[:-1]), "true_features"),
    "pose_error nan": (lambda: metrics.pose_error(FEATURES, NAN_FEATURES), "true_features"),
    "pose_error empty": (lambda: metrics.pose_error([], []), "pred_features"),
    "motion_error mismatched": (lambda: metrics.motion_error(WALK, WALK[:-1]), "true_positions"),
    "motion_error 2 coordinates": (lambda: metrics.motion_error(WALK[..., :2], WALK[..., :2]), "pred_positions"),
    "motion_error empty": (lambda: metrics.motion_error([], []), "pred_positions"),
    "window_errors 2-D": (lambda: metrics.window_errors(FEATURES, FEATURES, 20), "pred_features"),
    "window_errors mismatched": (lambda: metrics.window_errors(WINDOWS, WINDOWS[:1], 20), "true_features"),
    "window_errors 65 columns": (lambda: metrics.window_errors(WINDOWS[..., :65], WINDOWS[..., :65], 20),
                                 "pred_features"),
    "foot_skating 2 coordinates": (lambda: metrics.foot_skating(WALK[..., :2], 20), "positions"),
    "foot_skating one frame": (lambda: metrics.foot_skating(WALK[:1], 20), "positions"),
    "foot_skating nan": (lambda: metrics.foot_skating(WALK * NAN, 20), "positions"),
    "foot_skating foot 30": (lambda: metrics.foot_skating(WALK, 20, feet=(3, 30)), "feet"),
    "foot_skating contact 0": (lambda: metrics.foot_skating(WALK, 20, contact_height_m=0.0), "contact_height_m"),
    "foot_skating contact nan": (lambda: metrics.foot_skating(WALK, 20, contact_height_m=NAN), "contact_height_m"),
    "foot_skating 2 contacts": (lambda: metrics.foot_skating(WALK, 20, contact_height_m=(0.1, 0.1)),
                                "contact_height_m"),
    "bone_length_drift 20 joints": (lambda: metrics.bone_length_drift(WALK[:, :20]), "positions"),
    "bone_length_drift empty": (lambda: metrics.bone_length_drift([]), "positions"),
    "diversity 3-D": (lambda: metrics.diversity(SAMPLES[..., 0]), "samples"),
    "diversity one sample": (lambda: metrics.diversity(SAMPLES[:1]), "samples"),
    "diversity nan": (lambda: metrics.diversity(SAMPLES * NAN), "samples"),
    "stepping_speed joint 21": (lambda: metrics.stepping_speed(FEATURES, 20, joints=(3, 21)), "joints"),
    "stepping_speed 65 columns": (lambda: metrics.stepping_speed(FEATURES[:, :65], 20), "features"),
    "stepping_speed smooth_s nan": (lambda: metrics.stepping_speed(FEATURES, 20, smooth_s=NAN), "smooth_s"),
    "stepping_speed smooth_s < 0": (lambda: metrics.stepping_speed(FEATURES, 20, smooth_s=-0.1), "smooth_s"),
    "pose_spread empty": (lambda: metrics.pose_spread(np.zeros((2, 0, 66))), "features"),
    "pose_spread nan": (lambda: metrics.pose_spread(NAN_FEATURES), "features"),
    "leg_swing 64 columns": (lambda: metrics.leg_swing(FEATURES[:, :64]), "features"),
    "errors_by_frame 2-D": (lambda: metrics.errors_by_frame(FEATURES, FEATURES, 20), "pred_features"),
    "errors_by_frame nan": (lambda: metrics.errors_by_frame(WINDOWS, WINDOWS * NAN, 20), "true_features"),
    "describe_motion 2-D": (lambda: metrics.describe_motion(FEATURES), "features"),
    "summarize 20 joints": (lambda: metrics.summarize(WALK[:, :20], 20), "positions"),
    "distances_to_mean nan": (lambda: metrics.distances_to_mean([[NAN, 1.0], [1.0, 2.0]]), "points"),
    "distances_to_mean one point": (lambda: metrics.distances_to_mean(np.zeros((1, 3))), "points"),
    "data_band one frame": (lambda: metrics.data_band(np.zeros((1, 63))), "frames"),
    "mean_distance_over_time one sample": (lambda: metrics.mean_distance_over_time(SAMPLES[:1]), "samples"),
    "pairwise_distance_over_time nan": (lambda: metrics.pairwise_distance_over_time(SAMPLES * NAN), "samples"),
    "frame_speed one frame": (lambda: metrics.frame_speed(WINDOWS[:, :1], 20), "sequences"),
    "frame_speed empty": (lambda: metrics.frame_speed([], 20), "sequences"),
    "fraction_in_range reference nan": (lambda: metrics.fraction_in_range(WINDOWS, FEATURES * NAN), "reference"),
    "fraction_in_range reference width": (lambda: metrics.fraction_in_range(WINDOWS, FEATURES[:, :65]), "reference"),
    "fraction_in_range quantiles": (lambda: metrics.fraction_in_range(WINDOWS, FEATURES, quantiles=(0.5,)),
                                    "quantiles"),
    "fraction_in_range margin nan": (lambda: metrics.fraction_in_range(WINDOWS, FEATURES, margin=NAN), "margin"),
    "fraction_in_range atol < 0": (lambda: metrics.fraction_in_range(WINDOWS, FEATURES, atol=-1.0), "atol"),
    # viz
    "animate empty list": (lambda: viz.animate([], 20), "clips"),
    "animate 20 joints": (lambda: viz.animate([WALK, WALK[:, :20]], 20), r"clips\[1\]"),
    "animate nan": (lambda: viz.animate(WALK * NAN, 20), r"clips\[0\]"),
    "animate no frames": (lambda: viz.animate(WALK[:0], 20), r"clips\[0\]"),
    "animate step 0": (lambda: viz.animate(WALK, 20, step=0), "step"),
    "animate max_frames 0": (lambda: viz.animate(WALK, 20, max_frames=0), "max_frames"),
    "animate radius nan": (lambda: viz.animate(WALK, 20, radius=NAN), "radius"),
    "plot_skeleton 5 joints": (lambda: viz.plot_skeleton(np.zeros((5, 3))), "poses"),
    "plot_skeleton no poses": (lambda: viz.plot_skeleton(np.zeros((0, 21, 3))), "poses"),
    "plot_skeleton nan": (lambda: viz.plot_skeleton(WALK[0] * NAN), "poses"),
    "plot_trajectory 20 joints": (lambda: viz.plot_trajectory(WALK[:, :20], 20), "positions"),
    "plot_trajectory arrows 0 s": (lambda: viz.plot_trajectory(WALK, 20, arrow_every_s=0), "arrow_every_s"),
    "plot_controls 4 columns": (lambda: viz.plot_controls(np.zeros((5, 4)), 20), "control"),
    "plot_controls no frames": (lambda: viz.plot_controls(np.zeros((0, 3)), 20), "control"),
    "plot_controls empty list": (lambda: viz.plot_controls([], 20), "control"),
    "plot_frame frame 1.5": (lambda: viz.plot_frame(WALK, 1.5, 20), "frame"),
    "plot_frame frame -1": (lambda: viz.plot_frame(WALK, -1, 20), "frame"),
    "plot_frame frame 40": (lambda: viz.plot_frame(WALK, 40, 20), "frame"),
    "plot_frame 20 joints": (lambda: viz.plot_frame(WALK[:, :20], 0, 20), "positions"),
    "plot_filmstrip 65 columns": (lambda: viz.plot_filmstrip(FEATURES[:, :65]), "motion"),
    "plot_filmstrip n 0": (lambda: viz.plot_filmstrip(FEATURES, n=0), "n"),
    "plot_motion 65 columns": (lambda: viz.plot_motion(FEATURES[:, :65], 20), "features"),
    "plot_motion nan": (lambda: viz.plot_motion(NAN_FEATURES, 20), "features"),
    "plot_conv_filters names": (lambda: viz.plot_conv_filters(AE.encoder.weight, rep.FEATURE_NAMES[:65]), "weight"),
    # filters
    "gaussian_smooth empty": (lambda: filters.gaussian_smooth([], 2.0), "x"),
    "gaussian_smooth nan": (lambda: filters.gaussian_smooth(SIGNAL * NAN, 2.0), "x"),
    "gaussian_smooth scalar": (lambda: filters.gaussian_smooth(1.0, 2.0), "x"),
    "gaussian_smooth sigma nan": (lambda: filters.gaussian_smooth(SIGNAL, NAN), "sigma_frames"),
    "gaussian_smooth sigma < 0": (lambda: filters.gaussian_smooth(SIGNAL, -1), "sigma_frames"),
    "gaussian_smooth sigma 1e12": (lambda: filters.gaussian_smooth(SIGNAL, 1e12), "sigma_frames"),
    "lowpass cutoff 0": (lambda: filters.lowpass(SIGNAL, 0, 20), "cutoff_hz"),
    "lowpass cutoff nan": (lambda: filters.lowpass(SIGNAL, NAN, 20), "cutoff_hz"),
    "resample empty": (lambda: filters.resample(np.zeros((0, 3)), 120, 20), "x"),
    # the convolutional autoencoder
    "ConvAutoencoder forward nan": (lambda: AE(GOOD_X * NAN), "x"),
    "ConvAutoencoder forward 65 features": (lambda: AE(GOOD_X[..., :65]), "x"),
    "ConvAutoencoder forward odd frames": (lambda: AE(GOOD_X[:, :15]), "x"),
    "ConvAutoencoder forward no frames": (lambda: AE(GOOD_X[:, :0]), "x"),
    "ConvAutoencoder forward 2-D": (lambda: AE(GOOD_X[0]), "x"),
    "ConvAutoencoder forward numpy": (lambda: AE(GOOD_X.numpy()), "x"),
    "ConvAutoencoder project nan": (lambda: AE.project(GOOD_X * NAN), "x"),
    "ConvAutoencoder project 65 features": (lambda: AE.project(GOOD_X[..., :65]), "x"),
    "ConvAutoencoder encode inf": (lambda: AE.encode(GOOD_X + math.inf), "x"),
    "ConvAutoencoder encode odd frames": (lambda: AE.encode(GOOD_X[:, :3]), "x"),
    "ConvAutoencoder decode nan": (lambda: AE.decode(torch.full((2, 8, 8), NAN)), "y"),
    "ConvAutoencoder decode 7 filters": (lambda: AE.decode(torch.zeros(2, 8, 7)), "y"),
    "ConvAutoencoder loss 65 features": (lambda: AE.loss(GOOD_X[..., :65]), "batch"),
    "ConvAutoencoder trace 65 features": (lambda: AE.trace(GOOD_X[..., :65]), "x"),
    "ConvAutoencoder corrupt 65 features": (lambda: AE.corrupt(GOOD_X[..., :65]), "x"),
}


@pytest.mark.parametrize("call, name", BAD_CALLS.values(), ids=BAD_CALLS.keys())
def test_bad_arguments_are_named(call, name):
    with pytest.raises(ValueError, match=rf"^(\w+, )?{name}[:,]"):       # "x: ..." or "a, x: ..."
        call()


def test_the_messages_say_what_was_expected():
    with pytest.raises(ValueError, match=r"^features: expected shape \(frames, 66\), got \(0,\)$"):
        rep.to_positions([], 20)
    with pytest.raises(ValueError, match=r"^features: expected shape \(\.\.\., frames, 66\), got \(40, 65\)$"):
        rep.mirror_features(FEATURES[:, :65])
    with pytest.raises(ValueError, match=r"^joints: joint index 100 out of range \(0\.\.20\)$"):
        metrics.pose_error(FEATURES, FEATURES, joints=[100])
    with pytest.raises(ValueError, match=r"^fps: 1e\+12 is larger than the largest accepted value, 2000$"):
        rep.to_features(WALK, 1e12)
    with pytest.raises(ValueError, match=r"^x: expected \(batch, even frames, 66\), got \(2, 16, 65\)$"):
        AE(GOOD_X[..., :65])


def test_good_edge_values_still_work():
    assert rep.to_features(WALK, 2000).shape == (40, 66)                          # the highest rate
    assert np.array_equal(rep.to_features(WALK, np.float64(20)), FEATURES)
    assert np.array_equal(rep.to_features(WALK, 20), FEATURES)                    # an int rate
    assert rep.facing_angles(WALK, 20, facing_smoothing_s=0).shape == (40,)      # no smoothing
    assert metrics.stepping_speed(FEATURES, 20, smooth_s=0).shape == (39,)
    assert np.array_equal(filters.gaussian_smooth(SIGNAL, 0), SIGNAL)
    assert metrics.pose_error(FEATURES, FEATURES[:, rep.POSE], joints=np.array([0, 20])) == 0
    assert metrics.foot_skating(WALK, 20, contact_height_m=0.1) >= 0


def test_torch_tensors_are_accepted_like_numpy_arrays():
    walk, features = torch.from_numpy(WALK), torch.from_numpy(FEATURES)
    assert np.array_equal(rep.to_features(walk, 20), FEATURES)
    assert np.array_equal(rep.to_positions(features, 20), rep.to_positions(FEATURES, 20))
    assert np.array_equal(rep.mirror_features(features), rep.mirror_features(FEATURES))
    assert np.array_equal(rep.reverse_features(features, 20), rep.reverse_features(FEATURES, 20))
    assert metrics.pose_error(features.float(), FEATURES.astype(np.float32)) == 0
    assert metrics.foot_skating(walk, 20) == metrics.foot_skating(WALK, 20)
    assert np.array_equal(metrics.stepping_speed(features, 20), metrics.stepping_speed(FEATURES, 20))
    anim = viz.animate(walk[:3], 20)                       # one clip as a tensor: one panel
    assert len(anim._fig.axes) == 1


# the command line: a bad option is a usage error (exit code 2) that names it, not a traceback
BAD_OPTIONS = {
    "epochs 0": (["--epochs", "0"], "--epochs"),
    "epochs negative": (["--epochs", "-5"], "--epochs"),
    "epochs not a number": (["--epochs", "ten"], "--epochs"),
    "batch-size 0": (["--batch-size", "0"], "--batch-size"),
    "lr 0": (["--lr", "0"], "--lr"),
    "lr nan": (["--lr", "nan"], "--lr"),
    "lr inf": (["--lr", "inf"], "--lr"),
    "stride 0": (["--stride", "0"], "--stride"),
    "stride negative": (["--stride", "-1"], "--stride"),
    "data missing": (["--data", "/no/such/folder"], "--data"),
    "synthetic-clips 0": (["--synthetic-clips", "0"], "--synthetic-clips"),
    "seed negative": (["--seed", "-1"], "--seed"),
    "device unknown": (["--device", "gpu"], "--device"),
    "set unknown field": (["--set", "nope=1"], "--set"),
    "set not a number": (["--set", "filters=many"], "--set"),
    "set no value": (["--set", "filters"], "--set"),
    "set fps 0": (["--set", "fps=0"], "--set"),
    "set fps nan": (["--set", "fps=nan"], "--set"),
    "set odd window": (["--set", "window=81"], "--set"),
    "set bad choice": (["--set", "depool=magic"], "--set"),
}


@pytest.mark.parametrize("argv, option", BAD_OPTIONS.values(), ids=BAD_OPTIONS.keys())
def test_command_line_reports_bad_options(argv, option, capsys):
    from motionlab import train as cli
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["conv_ae", *argv])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "usage:" in err and option in err.split("error:")[-1]


def test_command_line_out_must_not_be_a_folder(tmp_path, capsys):
    from motionlab import train as cli
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["conv_ae", "--out", str(tmp_path)])
    assert exit_info.value.code == 2 and "--out" in capsys.readouterr().err


# ----------------------------------------------------------------------------------------
# Config dataclasses: every field checked by its type, the field named
# ----------------------------------------------------------------------------------------

def _configs():
    from motionlab.models.glow import GlowConfig
    from motionlab.models.lstm import LSTMConfig
    from motionlab.models.vae_lstm import VAELSTMConfig
    from motionlab.synthetic import Body, Style
    return [training.TrainConfig, ConvAEConfig, DFNConfig, GlowConfig, LSTMConfig, MoGlowConfig, VAEConfig,
            VAELSTMConfig, Body, Style]


def _bad_values(config, field):
    """Values a field of this annotation must refuse."""
    kind = str(field.type)
    if "bool" in kind:
        return [1, "yes", None]
    if "int" in kind and "tuple" not in kind:
        return [math.nan, 2.5, 64.0, "3", True, -1] + ([] if "None" in kind else [None])
    if "float" in kind:
        return [math.nan, math.inf, -math.inf, "0.1", True] + ([] if "None" in kind else [None])
    if kind == "str":
        return [3, None]
    return []


CONFIG_CASES = [(config, field.name, bad) for config in _configs() for field in dataclasses.fields(config)
                for bad in _bad_values(config, field)]


@pytest.mark.parametrize("config, name, bad", CONFIG_CASES,
                         ids=[f"{c.__name__}.{n}={b!r}" for c, n, b in CONFIG_CASES])
def test_every_config_field_refuses_a_bad_value_naming_the_field(config, name, bad):
    with pytest.raises(ValueError, match=rf"^{name}: "):
        config(**{name: bad})


@pytest.mark.parametrize("make, message", [
    (lambda: training.TrainConfig(batch_size=0), "batch_size"),
    (lambda: training.TrainConfig(lr=0.0), "lr"),
    (lambda: training.TrainConfig(min_lr_ratio=1.5), "min_lr_ratio"),
    (lambda: MoGlowConfig(fps=0), "fps"),
    (lambda: MoGlowConfig(fps=1e9), "fps"),
    (lambda: MoGlowConfig(hidden=0), "hidden"),
    (lambda: DFNConfig(observation_std=0.0), "observation_std"),
    (lambda: VAEConfig(beta=-1.0), "beta"),
], ids=["batch_size=0", "lr=0", "min_lr_ratio=1.5", "fps=0", "fps=1e9", "hidden=0", "observation_std=0", "beta=-1"])
def test_config_ranges_name_the_field(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_configs_take_numpy_numbers_and_give_python_ones():
    config = training.TrainConfig(epochs=np.int64(3), lr=np.float32(0.01), batch_size=8)
    assert type(config.epochs) is int and type(config.lr) is float and config.epochs == 3
    assert MoGlowConfig(fps=30).fps == 30.0 and type(MoGlowConfig(fps=30).fps) is float
    for config in _configs():
        config()                                                # every default is valid


@pytest.mark.parametrize("source", [123, 1.5, b"clips", None, [], [1, 2], {"a": 1}],
                         ids=["int", "float", "bytes", "None", "empty list", "list of ints", "dict"])
def test_data_load_says_what_sources_it_takes(source):
    with pytest.raises(ValueError, match=r"^source: .*(synthetic|file)"):
        data.load(source)
