"""foot_anchor: the feet's x, z modelled less where they would be had they stayed planted
since the previous frame. MoGlow's is an exact shift by the conditioning; Glow's a
triangular map over the window with ones on its diagonal, also exact."""
from dataclasses import replace

import numpy as np
import pytest
import torch

from motionlab import contacts, data, training
from motionlab.contacts import LEGS
from motionlab.models.anchor import FOOT_XZ as _FOOT_XZ
from motionlab.models.flows import ActNorm, ConvCouplingNet
from motionlab.models.glow import Glow, GlowConfig
from motionlab.models.moglow import MoGlow, MoGlowConfig
from motionlab.skeleton import FEET

SMALL = MoGlowConfig(window=16, history=4, steps=3, hidden=16)
ANCHORED = replace(SMALL, foot_anchor=True)
SEEN = replace(ANCHORED, anchor_conditioning=True)                   # the networks see m too
LEGGED = replace(SEEN, leg_anchor=True)                              # toes and knees relative to the leg
FPS = SMALL.fps


@pytest.fixture(scope="module")
def walker():
    """A built-in synthetic clip in data units ``(frames, 66)`` and a normaliser fitted on it."""
    features = data.load("synthetic", fps=FPS, n_clips=1, seed=3)[0].features()
    return features, data.Normalizer.fit(features)


def normalised(features, normalizer) -> torch.Tensor:
    x = torch.tensor(normalizer.normalize(features), dtype=torch.float32)
    x[..., [0, 2]] = 0.0
    return x


def trained_like(config, normalizer, seed=0):
    """A model whose couplings are no longer the identity, with ``normalizer``."""
    torch.manual_seed(seed)
    model = MoGlow(config)
    model.normalizer = normalizer
    model.loss(torch.randn(8, config.window, 66).index_fill_(-1, torch.tensor([0, 2]), 0.0))   # ActNorm's init
    with torch.no_grad():
        for network in model.flow.modules():
            if hasattr(network, "output") and isinstance(network.output, torch.nn.Linear):
                network.output.weight.normal_(0, 0.05)
    return model.eval()


def windows(features, normalizer, n=3, frames=16):
    x = normalised(features, normalizer)
    return torch.stack([x[17 * i:17 * i + frames] for i in range(n)])


def test_off_by_default_and_the_same_model_without_it():
    assert MoGlowConfig().foot_anchor is False
    plain, explicit = MoGlow(SMALL), MoGlow(replace(SMALL, foot_anchor=False))
    assert plain.state_dict().keys() == MoGlow(ANCHORED).state_dict().keys()     # checkpoints unchanged
    assert not hasattr(plain, "foot_columns") and plain.describe() == explicit.describe()


def test_a_planted_foot_has_no_residual(walker):
    # the residual x_t - m is R(θ)^-1 of the foot's world step (contacts.foot_velocity / fps):
    # 0 for a foot that stays put, the foot's whole step in the swing
    features, normalizer = walker
    model = MoGlow(ANCHORED)
    model.normalizer = normalizer
    x = normalised(features, normalizer)[None]
    poses, control = x[..., model.modelled], x[..., model.control]
    m = model.anchor(poses[:, :-1], control[:, :-1])
    std = torch.tensor(normalizer.std[list(_FOOT_XZ)], dtype=torch.float32)
    residual = ((poses[:, 1:, model.foot_columns] - m) * std).unflatten(-1, (2, len(FEET))).transpose(-1, -2)
    velocity = contacts.foot_velocity(torch.tensor(features)[None], FPS)
    assert torch.allclose(residual.norm(dim=-1).double(), velocity.norm(dim=-1) / FPS, atol=1e-5)
    stance = contacts.contact_labels(torch.tensor(features)[None], FPS).bool()
    assert stance.float().mean() > 0.3
    assert residual.norm(dim=-1)[stance].median() < 1e-5                  # metres
    assert residual.norm(dim=-1)[~stance].median() > 0.05


def test_the_likelihood_stays_exact(walker):
    # one predicted frame: its conditioning (the τ frames before it) is the same in both, so the
    # anchored model's likelihood is the plain one's (same weights) of the frame shifted by m,
    # computed here in metres: the shift adds nothing to the log-determinant
    features, normalizer = walker
    plain = trained_like(SMALL, normalizer)
    anchored = MoGlow(ANCHORED)
    anchored.load_state_dict(plain.state_dict())
    anchored.normalizer = normalizer
    anchored.eval()
    x = windows(features, normalizer, frames=SMALL.history + 1)
    in_units = torch.tensor(normalizer.denormalize(x.double().numpy()))
    previous, control = in_units[:, -2, list(_FOOT_XZ)], in_units[:, -2, -3:]
    theta = control[:, 2:3] / FPS
    px, pz = previous[:, :4] - control[:, 1:2] / FPS, previous[:, 4:] - control[:, 0:1] / FPS
    m = torch.cat([torch.cos(theta) * px - torch.sin(theta) * pz, torch.sin(theta) * px + torch.cos(theta) * pz], 1)
    shifted = x.clone()
    shifted[:, -1, list(_FOOT_XZ)] = ((in_units[:, -1, list(_FOOT_XZ)] - m) / torch.tensor(
        normalizer.std[list(_FOOT_XZ)])).float()
    assert torch.allclose(anchored.log_likelihood(x), plain.log_likelihood(shifted), atol=1e-3)
    assert not torch.allclose(plain.log_likelihood(x), plain.log_likelihood(shifted), atol=1e-3)
    nll = anchored.nll(windows(features, normalizer), normalizer)["bits/frame"]
    assert np.isfinite(nll)


def sampled_and_streamed(model, features, normalizer, flow_input):
    """Three 12-frame samples after 4 frames of the walk, drawn from fixed noise by
    ``model.sample`` and by its stream: ``(noise, z, streamed - sampled)``, where ``z`` is what
    the flow gives back for the samples whose input ``flow_input(poses, previous, controls)``
    makes as ``log_likelihood`` does."""
    x = windows(features, normalizer)
    history, control = x[:, :4], x[:, 4:, -3:]
    noise = torch.randn(3, 12, 61, generator=torch.Generator().manual_seed(1))
    sampled = model.sample(control, history, temperature=1.0, noise=noise)
    window = torch.cat([history, sampled], dim=1)
    poses, controls = window[..., model.modelled], window[..., model.control]
    with torch.no_grad():
        target = flow_input(poses[:, 4:], poses[:, 3:-1], controls[:, 3:-1])
        z, _ = model.flow(target, model.conditioning(poses, controls))
    return noise, z, model.stream(history, temperature=1.0).run(control, noise) - sampled


@pytest.mark.parametrize("config", [ANCHORED, SEEN, LEGGED], ids=["anchored", "m seen", "legs too"])
def test_sampling_inverts_the_likelihoods_map_and_the_stream_follows(walker, config):
    model = trained_like(config, walker[1])
    noise, z, streamed_less_sampled = sampled_and_streamed(   # the flow's input: the feet less m
        model, *walker, lambda poses, previous, controls: model._anchored(poses, previous, controls, -1.0))
    assert torch.allclose(z, noise, atol=1e-3)
    assert streamed_less_sampled.abs().max() < 1e-4


def test_generate_makes_finite_motion(walker):
    features, normalizer = walker
    model = trained_like(ANCHORED, normalizer)
    out = model.generate(features[10:50, -3:], prefix=features[:10], n=2, temperature=0.5)
    assert out.features.shape == (2, 40, 66) and np.isfinite(out.features).all()
    markov = trained_like(replace(ANCHORED, recurrent=False), normalizer)
    assert np.isfinite(markov.generate(features[10:30, -3:], prefix=features[:10], temperature=0.0).features).all()


@pytest.mark.parametrize("config", [ANCHORED, LEGGED], ids=["anchored", "legs too"])
def test_a_checkpoint_loads_back_with_its_shift(walker, tmp_path, config):
    features, normalizer = walker
    model = trained_like(config, normalizer)
    training.save_checkpoint(tmp_path / "anchored.pt", model, normalizer=normalizer, description={})
    loaded = training.load_checkpoint(tmp_path / "anchored.pt").model.eval()
    x = windows(features, normalizer)
    assert loaded.config == config and torch.allclose(loaded.log_likelihood(x), model.log_likelihood(x))


def test_errors_name_foot_anchor(walker):
    with pytest.raises(ValueError, match="foot_anchor"):
        MoGlowConfig(foot_anchor=1)
    with pytest.raises(ValueError, match="foot_anchor"):
        MoGlowConfig(foot_anchor=True, constant_features=(0, 2, 3 * FEET[0]))
    with pytest.raises(ValueError, match="foot_anchor"):
        MoGlow(ANCHORED).loss(windows(*walker))                           # no normaliser to measure m in


def test_anchor_conditioning_gives_the_networks_m_undropped(walker):
    features, normalizer = walker
    model = trained_like(SEEN, normalizer)
    assert model.cond_channels == MoGlow(ANCHORED).cond_channels + 8
    x = windows(features, normalizer)
    poses, controls = x[..., model.modelled], x[..., model.control]
    m = model.anchor(poses[:, 3:-1], controls[:, 3:-1])
    model.train()
    torch.manual_seed(0)
    dropped = model.conditioning(poses, controls, drop=True)
    assert torch.equal(dropped[..., -8:], m)                        # the history is dropped, m never
    assert (dropped[..., :-8] == 0).float().mean() > 0.5
    model.eval()
    assert torch.equal(model.conditioning(poses, controls)[..., -8:], m)   # nor scaled
    assert "anchor_conditioning" in model.describe()[-1]


def test_anchor_conditioning_needs_the_last_pose_and_the_anchor(walker):
    features, normalizer = walker
    model = trained_like(SEEN, normalizer)
    x = windows(features, normalizer)
    poses, controls = x[..., model.modelled], x[..., model.control]
    with pytest.raises(ValueError, match="previous"):
        model.frame_conditioning(poses[:, :4], controls[:, :5])
    with pytest.raises(ValueError, match="anchor_conditioning"):
        MoGlowConfig(anchor_conditioning=True)


# -- leg_anchor: toes and knees modelled relative to the leg of their own frame ---------

def in_metres(values, model, normalizer):
    """Modelled values ``(..., n_modelled)`` back in the data's units, as pose features ``(..., 63)``."""
    pose = torch.zeros(values.shape[:-1] + (63,), dtype=torch.float64)
    pose[..., model.modelled] = values.double()
    return pose * torch.tensor(normalizer.std[:63]) + torch.tensor(normalizer.mean[:63])


def test_leg_anchor_models_the_toe_less_its_ankle_and_the_knee_less_the_legs_midpoint(walker):
    features, normalizer = walker
    legged, feet_only = (trained_like(config, normalizer) for config in (LEGGED, SEEN))
    x = windows(features, normalizer, frames=SMALL.history + 1)
    poses, controls = x[..., legged.modelled], x[..., legged.control]
    with torch.no_grad():
        values = legged._anchored(poses[:, 1:], poses[:, :-1], controls[:, :-1], -1.0)
        anchored = feet_only._anchored(poses[:, 1:], poses[:, :-1], controls[:, :-1], -1.0)
    # the flow's values read in metres: the toe less its ankle, ...
    out, pose = in_metres(values, legged, normalizer), in_metres(poses[:, 1:], legged, normalizer)
    for hip, knee, ankle, toe in LEGS:
        for axis in (0, 2):
            assert torch.allclose(out[..., 3 * toe + axis], pose[..., 3 * toe + axis] - pose[..., 3 * ankle + axis], atol=1e-5)
        for axis in range(3):                    # ... the knee less the midpoint of its hip and ankle
            midpoint = (pose[..., 3 * hip + axis] + pose[..., 3 * ankle + axis]) / 2
            knee_value = out[..., 3 * knee + axis]
            assert torch.allclose(knee_value, pose[..., 3 * knee + axis] - midpoint, atol=1e-5)
    ankles = [legged.modelled.tolist().index(3 * leg[2] + axis) for leg in LEGS for axis in (0, 2)]
    assert torch.equal(values[..., ankles], anchored[..., ankles])      # the ankles less m, as before
    others = [i for i in range(legged.n_modelled) if i not in legged.leg_targets.tolist() + ankles]
    assert torch.equal(values[..., others], poses[:, 1:, others])       # nothing else moves


def test_leg_anchor_keeps_the_likelihood_exact(walker):
    # within a frame the toes and knees are shifted by hips and ankles that are not shifted by
    # them: the map's Jacobian is the identity plus a nilpotent part, log-determinant 0
    features, normalizer = walker
    model = trained_like(LEGGED, normalizer)
    x = windows(features, normalizer, n=1, frames=2)
    poses, controls = x[..., model.modelled], x[..., model.control]
    jacobian = torch.autograd.functional.jacobian(
        lambda v: model._anchored(v[None, None], poses[:, 0], controls[:, 0], -1.0)[0, 0], poses[0, 1])
    assert torch.equal(torch.diagonal(jacobian), torch.ones(model.n_modelled))
    assert torch.slogdet(jacobian.double()).logabsdet.abs() < 1e-9
    off = jacobian - torch.eye(model.n_modelled)
    assert off.abs().max() > 0.1 and torch.equal(off @ off, torch.zeros_like(off))   # it shifts; nilpotent
    values = model._anchored(poses[:, 1:], poses[:, :1], controls[:, :1], -1.0)
    assert torch.allclose(model._anchored(values, poses[:, :1], controls[:, :1], 1.0), poses[:, 1:], atol=1e-5)
    assert "leg_anchor" in model.describe()[-1] and "leg_anchor" not in " ".join(MoGlow(SEEN).describe())


def test_leg_anchor_errors_name_it(walker):
    with pytest.raises(ValueError, match="leg_anchor: .*needs foot_anchor=True"):
        MoGlowConfig(leg_anchor=True)
    with pytest.raises(ValueError, match="leg_anchor"):
        MoGlowConfig(foot_anchor=True, leg_anchor="yes")
    with pytest.raises(ValueError, match="leg_anchor"):
        MoGlowConfig(foot_anchor=True, leg_anchor=True, constant_features=(0, 2, 3 * LEGS[0][1] + 1))
    with pytest.raises(ValueError, match="leg_anchor"):
        GlowConfig(leg_anchor=True)
    assert MoGlowConfig().leg_anchor is False and GlowConfig().leg_anchor is False


# -- Glow: the previous frame is modelled, so the map is triangular over the window -----

GLOW = GlowConfig(window=16, levels=2, steps=2, hidden=16)
GLOW_ANCHORED = replace(GLOW, foot_anchor=True)


def glow_like(config, normalizer, x, seed=0):
    """A Glow whose couplings and ActNorms are moved off their start, initialised on ``x``."""
    torch.manual_seed(seed)
    model = Glow(config)
    model.normalizer = normalizer
    with torch.no_grad():
        for module in model.modules():
            if isinstance(module, (ActNorm, ConvCouplingNet)):
                for p in module.parameters():
                    p.add_(0.05 * torch.randn_like(p))
    model.log_likelihood(x)                                      # ActNorm's data-dependent start
    return model.eval()


@pytest.mark.parametrize("legs", [False, True], ids=["feet", "legs too"])
def test_glow_the_window_map_is_triangular_with_a_unit_diagonal(walker, legs):
    features, normalizer = walker
    model = Glow(replace(GLOW_ANCHORED, leg_anchor=legs))
    model.normalizer = normalizer
    x = windows(features, normalizer, n=1, frames=8)
    values, control = model.split_features(x)
    jacobian = torch.autograd.functional.jacobian(
        lambda v: model.anchor_window(v.view_as(values), control, -1.0).flatten(), values.flatten())
    n = values.shape[-1]
    by_frame = jacobian.unflatten(0, (8, n)).unflatten(2, (8, n)).abs().sum((1, 3))
    assert torch.equal(torch.triu(by_frame, 1), torch.zeros_like(by_frame))     # frame t sees frames <= t only
    within = jacobian.unflatten(0, (8, n)).unflatten(2, (8, n))[3, :, 3] - torch.eye(n)
    assert torch.equal(within @ within, torch.zeros_like(within))              # within a frame: nilpotent
    assert within.abs().max() > (0.1 if legs else -1.0)
    assert torch.equal(torch.diagonal(jacobian), torch.ones(jacobian.shape[0]))
    assert torch.slogdet(jacobian.double()).logabsdet.abs() < 1e-9
    assert (jacobian - torch.eye(jacobian.shape[0])).abs().max() > 0.1         # and it does shift the feet


def test_glow_the_likelihood_is_the_plain_flows_of_the_window_less_m(walker):
    # every frame but the first less m, computed here in metres from the frame before it
    features, normalizer = walker
    x = windows(features, normalizer)
    plain = glow_like(GLOW, normalizer, x)
    anchored = Glow(GLOW_ANCHORED)
    anchored.load_state_dict(plain.state_dict())
    anchored.normalizer = normalizer
    anchored.eval()
    in_units = torch.tensor(normalizer.denormalize(x.double().numpy()))
    previous, control = in_units[:, :-1, list(_FOOT_XZ)], in_units[:, :-1, -3:]
    theta = control[..., 2:3] / FPS
    px, pz = previous[..., :4] - control[..., 1:2] / FPS, previous[..., 4:] - control[..., 0:1] / FPS
    m = torch.cat([torch.cos(theta) * px - torch.sin(theta) * pz, torch.sin(theta) * px + torch.cos(theta) * pz], -1)
    shifted = x.clone()
    shifted[:, 1:, list(_FOOT_XZ)] = ((in_units[:, 1:, list(_FOOT_XZ)] - m) / torch.tensor(
        normalizer.std[list(_FOOT_XZ)])).float()
    assert torch.allclose(anchored.log_likelihood(x), plain.log_likelihood(shifted), atol=1e-3)
    assert not torch.allclose(plain.log_likelihood(x), plain.log_likelihood(shifted), atol=1e-3)
    assert np.isfinite(anchored.nll(x, normalizer)["bits/frame"])


@pytest.mark.parametrize("legs", [False, True], ids=["feet", "legs too"])
def test_glow_sampling_inverts_the_likelihoods_map(walker, legs):
    features, normalizer = walker
    x = windows(features, normalizer)
    model = glow_like(replace(GLOW_ANCHORED, leg_anchor=legs), normalizer, x)
    z = torch.randn(3, 16 * model.n_modelled, generator=torch.Generator().manual_seed(1))
    sampled = model.decode(z, x[..., -3:])
    back, _ = model.encode(sampled)
    assert torch.allclose(back, z, atol=1e-3)
    out = model.generate(features[:16, -3:], n=2, temperature=0.5)
    assert out.features.shape == (2, 16, 66) and np.isfinite(out.features).all()


def test_glow_a_checkpoint_loads_back_with_its_shift(walker, tmp_path):
    features, normalizer = walker
    x = windows(features, normalizer)
    model = glow_like(GLOW_ANCHORED, normalizer, x)
    training.save_checkpoint(tmp_path / "anchored.pt", model, normalizer=normalizer, description={})
    loaded = training.load_checkpoint(tmp_path / "anchored.pt").model.eval()
    assert loaded.config.foot_anchor and torch.allclose(loaded.log_likelihood(x), model.log_likelihood(x))
    assert "foot_anchor" in loaded.describe()[-1] and "foot_anchor" not in " ".join(Glow(GLOW).describe())


def test_glow_errors_name_foot_anchor(walker):
    with pytest.raises(ValueError, match="foot_anchor: the shift is a function of the control"):
        GlowConfig(foot_anchor=True, conditional=False)
    with pytest.raises(ValueError, match="foot_anchor"):
        GlowConfig(foot_anchor=True, constant_features=(0, 2, 3 * FEET[1] + 2))
    with pytest.raises(ValueError, match="foot_anchor"):
        GlowConfig(foot_anchor="yes")
    with pytest.raises(ValueError, match="foot_anchor"):
        Glow(GLOW_ANCHORED).loss(windows(*walker))                        # no normaliser to measure m in
