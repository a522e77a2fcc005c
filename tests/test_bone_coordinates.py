"""bone_coordinates: MoGlow models the spine's, neck's, head's and arms' joints by each bone's
change of length since the previous frame and its direction. The map is a bijection given the
previous frame whose log-determinant is added (the likelihood stays exact), sampling and the
stream invert it, and a bone whose length change the flow leaves at 0 keeps its length."""
from dataclasses import replace

import numpy as np
import pytest
import torch

from motionlab import metrics, training
from motionlab.models import bone_coordinates as bones
from motionlab.models.moglow import MoGlow, MoGlowConfig
from motionlab.representation import to_positions
from motionlab.skeleton import LOCOMOTION

from test_foot_anchor import LEGGED, SMALL, sampled_and_streamed, walker, windows  # noqa: F401 (walker: a fixture)

BONED = replace(SMALL, bone_coordinates=True)
BONED_LEGGED = replace(LEGGED, bone_coordinates=True)                # the shipped kind: feet and legs anchored too
UPPER = [k for k, (_, child) in enumerate(LOCOMOTION.bones) if child >= bones.FIRST_UPPER_JOINT]


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
    with pytest.raises(ValueError, match="bone_coordinates: the spine's"):
        MoGlowConfig(bone_coordinates=True, constant_features=(0, 2, 3 * 14))
    with pytest.raises(ValueError, match="bone_coordinates"):
        MoGlow(BONED).loss(windows(*walker))                              # no normaliser to measure bones in
    assert MoGlow(BONED).describe()[-1].endswith("(bone_coordinates)")


def walk_in_bones(walker):
    """A model with the option, the walk's modelled poses ``(3, 16, 61)``, the flow's values
    of frames 1.. given the frames before, and the bones' columns ``(12, 3)``: l, s1, s2."""
    features, normalizer = walker
    model = model_with(BONED, normalizer)
    poses = windows(features, normalizer)[..., model.modelled]
    y, _ = model.to_bones(poses[:, 1:], poses[:, :-1])
    return model, poses, y, model._bone_units(y.device).columns


def test_the_map_inverts_and_the_datas_lengths_do_not_change(walker):
    model, poses, y, columns = walk_in_bones(walker)
    assert y[..., columns[:, 0]].abs().max() < 0.05            # l: the data's bones keep their length (units of K)
    others = [c for c in range(y.shape[-1]) if c not in columns.flatten().tolist()]
    assert torch.equal(y[..., others], poses[:, 1:, others])    # the hips and legs pass unchanged
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
    np.testing.assert_allclose(lengths[..., UPPER], before[..., UPPER], rtol=1e-4)


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


def test_a_trained_model_keeps_its_upper_bones_and_a_checkpoint_keeps_the_option(walker, tmp_path):
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
        lengths = LOCOMOTION.bone_lengths(motion.positions)[..., UPPER]
        drift[name] = float((lengths.std(axis=1) / lengths.mean(axis=1)).mean())
        if name == "bones":
            training.save_checkpoint(tmp_path / "bones.pt", model, normalizer=normalizer, description={})
            loaded = training.load_checkpoint(tmp_path / "bones.pt").model.eval()
            assert loaded.config.bone_coordinates is True
            assert torch.allclose(loaded.log_likelihood(x), model.log_likelihood(x), atol=1e-3)
    assert drift["bones"] < 0.01 and drift["free"] > 5 * drift["bones"], drift
    assert np.isfinite(motion.positions).all() and metrics.bone_length_drift(motion.positions) > 0   # legs: free


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
