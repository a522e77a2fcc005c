"""bone_coordinates: MoGlow models every joint but the hips and ankles (with anchored legs: the
spine's, neck's, head's and arms') by each bone's change of length since the previous frame and
its direction. The map is a bijection given the
previous frame whose log-determinant is added (the likelihood stays exact), sampling and the
stream invert it, and a bone whose length change the flow leaves at 0 keeps its length."""
from dataclasses import replace

import numpy as np
import pytest
import torch

from motionlab import metrics, training
from motionlab.models import bone_coordinates as bones
from motionlab.models.glow import FIRST_FRAME_UNIT, Glow, GlowConfig
from motionlab.models.moglow import MoGlow, MoGlowConfig
from motionlab.representation import to_positions
from motionlab.skeleton import LOCOMOTION

from test_foot_anchor import (GLOW, LEGGED, SMALL, glow_like, sampled_and_streamed, walker,  # noqa: F401 (walker:
                              windows)                                                    # a fixture)

BONED = replace(SMALL, bone_coordinates=True)
BONED_LEGGED = replace(LEGGED, bone_coordinates=True)                # the shipped kind: feet and legs anchored too
MODELLED = [k for k, (parent, child) in enumerate(LOCOMOTION.bones) if (child, parent) in bones.bones_of(BONED)]
"""The bones (``LOCOMOTION.bones`` order) the unanchored option models: every one but the shins."""


def model_with(config, normalizer) -> MoGlow:
    model = MoGlow(config)
    model.normalizer = normalizer
    return model


def trained_on_data(config, features, normalizer) -> MoGlow:
    """As test_foot_anchor's ``trained_like``, its ActNorm initialised on real windows: random
    poses have random bone lengths, whose changes of length (in units of K) are thousands."""
    torch.manual_seed(0)
    model = model_with(config, normalizer)
    model.loss(windows(features, normalizer, n=6))                    # ActNorm's init
    with torch.no_grad():
        for network in model.flow.modules():
            if hasattr(network, "output") and isinstance(network.output, torch.nn.Linear):
                network.output.weight.normal_(0, 0.05)
    return model.eval()


def test_off_by_default_and_refuses_what_it_cannot_serve(walker):
    assert MoGlowConfig().bone_coordinates is False
    assert MoGlow(SMALL).state_dict().keys() == MoGlow(BONED).state_dict().keys()   # no weights of its own
    with pytest.raises(ValueError, match="bone_coordinates: needs the locomotion features"):
        MoGlowConfig(n_features=60, bone_coordinates=True)
    with pytest.raises(ValueError, match="bone_coordinates: the values of a joint modelled by its bone"):
        MoGlowConfig(bone_coordinates=True, constant_features=(0, 2, 3 * 14))
    with pytest.raises(ValueError, match="bone_coordinates"):
        MoGlow(BONED).loss(windows(*walker))                              # no normaliser to measure bones in
    assert MoGlow(BONED).describe()[-1].endswith("(bone_coordinates)")


def test_which_bones_every_one_but_the_shins_or_the_upper_bodys_with_anchored_legs():
    names = LOCOMOTION.names
    shins = {(names.index(f"{side}Foot"), names.index(f"{side}Leg")) for side in ("Left", "Right")}
    assert set(bones.bones_of(BONED)) == set(bones.ALL_BONES) - shins and len(MODELLED) == 18
    assert bones.bones_of(BONED_LEGGED) == bones.bones_of(replace(SMALL, foot_anchor=True)) == bones.UPPER_BONES
    assert all(child >= bones.FIRST_UPPER_JOINT for child, _ in bones.UPPER_BONES) and len(bones.UPPER_BONES) == 12
    placed = [child for child, _ in bones.bones_of(BONED)]          # parents first: each placed from a joint known
    assert all(parent in (0, *bones.ANKLES, *placed[:k]) for k, (_, parent) in enumerate(bones.bones_of(BONED)))


def walk_in_bones(walker):
    """A model with the option, the walk's modelled poses ``(3, 16, 61)``, the flow's values
    of frames 1.. given the frames before, and the bones' columns ``(18, 3)``: l, s1, s2."""
    features, normalizer = walker
    model = model_with(BONED, normalizer)
    poses = windows(features, normalizer)[..., model.modelled]
    y, _ = model.to_bones(poses[:, 1:], poses[:, :-1])
    return model, poses, y, model._bone_units(y.device).columns


def test_the_map_inverts_and_the_datas_lengths_do_not_change(walker):
    model, poses, y, columns = walk_in_bones(walker)
    assert y[..., columns[:, 0]].abs().max() < 0.05            # l: the data's bones keep their length (units of K)
    others = [c for c in range(y.shape[-1]) if c not in columns.flatten().tolist()]
    assert torch.equal(y[..., others], poses[:, 1:, others])    # the hips and ankles pass unchanged
    assert torch.allclose(model.from_bones(y, poses[:, :-1]), poses[:, 1:], atol=1e-4)


def test_the_log_determinant_is_the_jacobians(walker):
    features, normalizer = walker
    model = model_with(BONED, normalizer)
    poses = windows(features, normalizer)[0, :, model.modelled].double()
    previous, frame = poses[5], poses[6].clone().requires_grad_(True)
    jacobian = torch.autograd.functional.jacobian(lambda x: model.to_bones(x, previous)[0].double(), frame)
    _, expected = torch.linalg.slogdet(jacobian)
    _, logdet = model.to_bones(frame.detach(), previous)
    assert abs(float(logdet) - float(expected)) < 1e-3 * abs(float(expected)) + 1e-3


def test_a_bone_whose_length_change_is_zero_keeps_its_length(walker):
    features, normalizer = walker
    model, poses, y, columns = walk_in_bones(walker)
    y[..., columns[:, 0]] = 0.0                                             # every l 0 ...
    y[..., columns[:, 1:].flatten()] += 0.2 * torch.randn_like(y[..., columns[:, 1:].flatten()])   # ... any direction
    placed = model.from_bones(y, poses[:, :-1])
    control = windows(features, normalizer)[:, 1:, -3:]

    def lengths_of(p):                                                      # (3, frames, 20) metres
        features_ = normalizer.denormalize(model.join_features(p, control).double().numpy())
        return LOCOMOTION.bone_lengths(to_positions(features_, SMALL.fps))

    lengths, before = lengths_of(placed), lengths_of(poses[:, :-1])
    np.testing.assert_allclose(lengths[..., MODELLED], before[..., MODELLED], rtol=1e-4)


@pytest.mark.parametrize("config", [BONED, BONED_LEGGED], ids=["bones", "feet and legs anchored too"])
def test_sampling_inverts_the_likelihoods_map_and_the_stream_follows(walker, config):
    model = trained_on_data(config, *walker)

    def flow_input(poses, previous, controls):                  # as log_likelihood makes it
        target, _ = model.to_bones(poses, previous)
        return model._anchored(target, previous, controls, -1.0) if config.foot_anchor else target

    noise, z, streamed_less_sampled = sampled_and_streamed(model, *walker, flow_input)
    # float32 positions hold a bone's log-length to about 1e-7: 1e-3 in units of K = 1e-4
    assert torch.allclose(z, noise, atol=2e-2) and (z - noise).abs().median() < 3e-3
    assert streamed_less_sampled.abs().max() < 1e-4


def test_a_trained_model_keeps_its_bones_and_a_checkpoint_keeps_the_option(walker, tmp_path):
    features, normalizer = walker
    drift = {}
    for name, model_config in (("free", SMALL), ("bones", BONED)):
        torch.manual_seed(0)
        model = MoGlow(model_config)
        x = windows(features, normalizer, n=6)
        model.normalizer = normalizer
        optimizer = torch.optim.Adam(model.parameters(), lr=3e-3)
        for _ in range(30):
            optimizer.zero_grad()
            loss = model.loss(x)["loss"]
            assert torch.isfinite(loss)
            loss.backward()
            optimizer.step()
        model.eval()
        motion = model.generate(features[10:70, -3:], prefix=features[:10], n=2, temperature=0.3, seed=0)
        lengths = LOCOMOTION.bone_lengths(motion.positions)[..., MODELLED]
        drift[name] = float((lengths.std(axis=1) / lengths.mean(axis=1)).mean())
        if name == "bones":
            training.save_checkpoint(tmp_path / "bones.pt", model, normalizer=normalizer, description={})
            loaded = training.load_checkpoint(tmp_path / "bones.pt").model.eval()
            assert loaded.config.bone_coordinates is True
            assert torch.allclose(loaded.log_likelihood(x), model.log_likelihood(x), atol=1e-3)
    assert drift["bones"] < 0.01 and drift["free"] > 5 * drift["bones"], drift
    assert np.isfinite(motion.positions).all() and metrics.bone_length_drift(motion.positions) > 0   # shins: free


def test_a_stream_before_training_leaves_nothing_in_inference_mode(walker):
    # the map's units are cached per normaliser; made under a stream's inference mode they
    # would break the next training step's backward pass
    features, normalizer = walker
    model = trained_on_data(BONED, features, normalizer)
    x = windows(features, normalizer)
    model.stream(x[:, :4], temperature=0.5).run(x[:, 4:, -3:])
    model.train()
    model.loss(x)["loss"].backward()
    assert all(torch.isfinite(p.grad).all() for p in model.parameters() if p.grad is not None)


# -- Glow: the frame before is in the window, so the map is block-triangular over time ------

GLOW_BONED = replace(GLOW, bone_coordinates=True)


def test_glow_refuses_what_it_cannot_serve_and_keeps_its_weights():
    assert GlowConfig().bone_coordinates is False
    assert Glow(GLOW).state_dict().keys() == Glow(GLOW_BONED).state_dict().keys()
    with pytest.raises(ValueError, match="bone_coordinates: models the pose given the control"):
        replace(GLOW_BONED, conditional=False)
    assert "bone_coordinates" in Glow(GLOW_BONED).describe()[-1]


def test_glow_the_windows_log_determinant_is_the_jacobians(walker):
    features, normalizer = walker
    model = model_with_glow(normalizer)
    values, _ = model.split_features(windows(features, normalizer, n=1, frames=4))
    values = values.double()
    jacobian = torch.autograd.functional.jacobian(lambda v: model.window_to_bones(v.view_as(values))[0].flatten(),
                                                  values.flatten())
    _, expected = torch.linalg.slogdet(jacobian)
    _, logdet = model.window_to_bones(values)
    assert abs(float(logdet) - float(expected)) < 1e-3 * abs(float(expected)) + 1e-3
    n = values.shape[-1]
    by_frame = jacobian.unflatten(0, (4, n)).unflatten(2, (4, n)).abs().sum((1, 3))
    assert torch.equal(torch.triu(by_frame, 1), torch.zeros_like(by_frame))     # frame t sees frames <= t only


def model_with_glow(normalizer) -> Glow:
    model = Glow(GLOW_BONED)
    model.normalizer = normalizer
    return model.eval()


def test_glow_sampling_inverts_the_likelihoods_map_and_keeps_the_first_frames_lengths(walker):
    features, normalizer = walker
    x = windows(features, normalizer)
    model = glow_like(GLOW_BONED, normalizer, x)
    z = torch.randn(3, 16 * model.n_modelled, generator=torch.Generator().manual_seed(1))
    sampled = model.decode(z, x[..., -3:])
    back, _ = model.encode(sampled)
    assert torch.allclose(back, z, atol=2e-2) and (back - z).abs().median() < 3e-3   # float32 lengths, units of K
    values, _ = model.split_features(x)
    y, _ = model.window_to_bones(values)
    y[:, 1:, model._bone_units(y.device).columns[:, 0]] = 0.0                # no length ever changes ...
    lengths = LOCOMOTION.bone_lengths(to_positions(
        normalizer.denormalize(model.join_features(model.window_from_bones(y), x[..., -3:]).double().numpy()),
        GLOW.fps))
    kept = np.broadcast_to(lengths[:, :1, MODELLED], lengths[..., MODELLED].shape)   # ... so every frame keeps
    np.testing.assert_allclose(lengths[..., MODELLED], kept, rtol=1e-4)                # the first frame's lengths
    first, _ = model.to_bones(values[:, :1], torch.zeros_like(values[:, :1]), FIRST_FRAME_UNIT)
    assert torch.equal(model.window_to_bones(values)[0][:, :1], first)      # the first frame: against the mean pose
    out = model.generate(features[:16, -3:], n=2, temperature=0.5)
    assert out.features.shape == (2, 16, 66) and np.isfinite(out.features).all()


def test_glows_window_of_bones_is_placed_at_once_as_frame_by_frame(walker):
    # the running sum of the log-lengths over the window is the frame-by-frame inverse
    features, normalizer = walker
    x = windows(features, normalizer)
    model = glow_like(GLOW_BONED, normalizer, x)
    y = model.flow.inverse(0.7 * torch.randn(3, 16 * model.n_modelled, generator=torch.Generator().manual_seed(2)),
                           x[..., -3:])
    frames = [model.from_bones(y[:, 0], torch.zeros_like(y[:, 0]), FIRST_FRAME_UNIT)]
    for t in range(1, y.shape[1]):
        frames.append(model.from_bones(y[:, t], frames[-1]))
    assert torch.allclose(model.window_from_bones(y), torch.stack(frames, dim=1), atol=1e-4)
