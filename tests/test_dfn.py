"""Dynamic Future Net (Chen et al. 2020): shapes, KL terms, staged training, generation."""
import math
from dataclasses import replace

import numpy as np
import pytest
import torch
from torch.distributions import Normal, kl_divergence

from motionlab import data, metrics, training
from motionlab import representation as rep
from motionlab.models.dfn import DFN, STAGES, DFNConfig, ForwardKinematics, quaternion_to_matrix
from motionlab.rotations import forward_kinematics
from motionlab.skeleton import LOCOMOTION
from motionlab.training import train_stages

SMALL = DFNConfig(frame_hidden=32, pose_code=6, velocity_code=2, horizon=4, summary=8, past=16,
                  future=4, current=4, future_prior_hidden=16, current_prior_hidden=16,
                  summary_decoder_hidden=16, current_posterior_hidden=8, future_posterior_hidden=16,
                  td_hidden=8, td_max_skip=2)


@pytest.fixture(scope="module")
def prepared():
    clips = data.load("synthetic", n_clips=8, duration_s=6.0)
    return data.prepare(clips, window_s=1.0, stride_s=0.5, augment_with=("mirror",))


def staged(model, windows):
    """Put a fresh model in the dynamics stage (standardisation fitted on ``windows``)."""
    model.set_stage("sequence", windows)
    model.set_stage("dynamics", windows)
    return model


def test_config_checks_and_paper_sizes():
    paper = DFNConfig.paper()
    assert (paper.past, paper.future_prior_hidden, paper.current_prior_hidden) == (128, 256, 128)
    assert (paper.current_posterior_hidden, paper.future_posterior_hidden, paper.td_hidden) == (32, 512, 32)
    assert paper.pose_code == 16 and paper.code == paper.pose_code + paper.velocity_code
    assert DFNConfig.paper(horizon=5).horizon == 5
    for bad in ({"horizon": 0}, {"observation_std": 0.0}, {"td_weight": -1.0}, {"fps": 0.0},
                {"prior_feed": 1.0}, {"prior_feed": -0.1}, {"prior_feed": math.nan}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            DFNConfig(**bad)


def test_paper_network_shapes():
    # §5.3: 2-layer GRU of 128; p(f | h) a three-layer MLP, 256 wide, LeakyReLU
    model = DFN(DFNConfig.paper())
    d = model.dynamics
    assert [cell.hidden_size for cell in d.past] == [128, 128]
    linears = [m for m in d.future_prior.net if isinstance(m, torch.nn.Linear)]
    assert [m.out_features for m in linears[:-1]] == [256, 256] and len(linears) == 3
    assert any(isinstance(m, torch.nn.LeakyReLU) for m in d.future_prior.net)
    assert len([m for m in d.current_prior.net if isinstance(m, torch.nn.Linear)]) == 4     # four-layer
    assert len([m for m in d.skip if isinstance(m, torch.nn.Linear)]) == 4                  # 3 hidden layers
    windows = torch.randn(6, 24, 66)                                   # the paper's sizes run end to end
    model.set_stage("frame", windows)
    model.set_stage("sequence", windows)
    model.set_stage("dynamics", windows)
    assert torch.isfinite(model.loss(windows[:2])["loss"])
    assert model.sample(windows[:2, :8], 12).shape == (2, 12, 66)


def test_shapes(prepared):
    torch.manual_seed(0)
    model = DFN(SMALL)
    x = prepared.train.windows[:3]                                     # (3, 20, 66)
    assert model.frame.encode(x).shape == (3, 20, SMALL.code)
    assert model.reconstruct(x).shape == x.shape
    assert model.reconstruct(x, through="sequence").shape == (3, 20, 66)   # 5 pieces of 4
    assert model.summaries(model.codes(x)).shape == (3, 20 - SMALL.horizon + 1, SMALL.summary)
    out = staged(model, prepared.train.windows).infer(x)
    steps = 20 - SMALL.horizon + 1
    for key, size in [("h", SMALL.past), ("f", SMALL.future), ("z", SMALL.current), ("x_hat", SMALL.code),
                      ("s_hat", SMALL.summary), ("qz_mu", SMALL.current), ("pf_log_var", SMALL.future)]:
        assert out[key].shape == (3, steps, size), key


def test_each_kl_term_of_the_loss_matches_torch(prepared):
    torch.manual_seed(0)
    model = staged(DFN(SMALL), prepared.train.windows)
    batch = prepared.train.windows[:4]
    torch.manual_seed(1)
    with torch.no_grad():
        terms = model.loss(batch)
    torch.manual_seed(1)
    with torch.no_grad():
        out = model.infer(batch)
    normal = lambda mu, log_var: Normal(mu, (0.5 * log_var).exp())          # noqa: E731
    kl_z = kl_divergence(normal(out["qz_mu"], out["qz_log_var"]), normal(out["pz_mu"], out["pz_log_var"]))
    kl_f = kl_divergence(normal(out["qf_mu"], out["qf_log_var"]), normal(out["pf_mu"], out["pf_log_var"]))
    assert float(terms["kl_z"]) == pytest.approx(float(kl_z.sum(-1).mean()), rel=1e-4)   # q(z|x,h,s) || p(z|h,s^)
    assert float(terms["kl_f"]) == pytest.approx(float(kl_f.sum(-1).mean()), rel=1e-4)   # q(f|h,s) || p(f|h)
    td = model.td_terms(out, skip=2)                                                        # §5.5
    kl_td = kl_divergence(normal(td["td_mu"], td["td_log_var"]),
                          normal(out["qz_mu"][:, :-2], out["qz_log_var"][:, :-2])).sum(-1)
    assert torch.allclose(td["td_kl"], kl_td, rtol=1e-4, atol=1e-5)
    assert td["td_kl"].shape == (4, out["z"].shape[1] - 2)
    total = sum(float(terms[k]) for k in ("x_nll", "s_nll", "kl_z", "kl_f", "td"))
    assert float(terms["loss"]) == pytest.approx(total, rel=1e-4)


def test_constant_features_are_decoded_exactly(prepared):
    # the hips' root-local x and z are 0 in every frame: the frame decoder returns them as is
    model = DFN(SMALL)
    windows = prepared.train.windows
    model.set_stage("frame", windows)
    hips_xz = [0, 2]
    assert model.frame.constant.nonzero().flatten().tolist() == hips_xz
    decoded = model.reconstruct(windows[:4])
    assert torch.equal(decoded[..., hips_xz], windows[:4, :, hips_xz])
    assert not torch.allclose(decoded[..., 1], windows[:4, :, 1])       # an untrained hips height


def test_stages_freeze_the_others(prepared):
    model = DFN(SMALL)
    model.set_stage("frame")
    assert all(p.requires_grad for p in model.frame.parameters())
    assert not any(p.requires_grad for p in model.dynamics.parameters())
    staged(model, prepared.train.windows)
    assert not any(p.requires_grad for p in model.frame.parameters())
    assert not any(p.requires_grad for p in model.sequence.parameters())
    assert all(p.requires_grad for p in model.dynamics.parameters())
    # standardised codes of the training windows
    codes = model.codes(prepared.train.windows).reshape(-1, SMALL.code)
    assert torch.allclose(codes.mean(0), torch.zeros(SMALL.code), atol=1e-4)
    assert torch.allclose(codes.std(0), torch.ones(SMALL.code), atol=1e-3)
    model.set_stage("dynamics", prepared.train.windows)                 # again: same standardisation
    summaries = model.summaries(model.codes(prepared.train.windows)).reshape(-1, SMALL.summary)
    assert torch.allclose(summaries.mean(0), torch.zeros(SMALL.summary), atol=1e-4)
    assert torch.allclose(summaries.std(0), torch.ones(SMALL.summary), atol=1e-3)


@pytest.mark.slow
def test_staged_training_improves_every_stage(prepared):
    torch.manual_seed(0)
    model = DFN(SMALL)
    frozen = {}

    def config(steps):
        return training.TrainConfig(epochs=100, max_steps=steps, batch_size=16, lr=3e-3, progress=False)

    histories = {}
    for stage, steps in zip(STAGES, (100, 150, 100)):
        before = {name: p.detach().clone() for name, p in model.named_parameters()}
        histories.update(train_stages(model, prepared.train, {stage: config(steps)}, stages=(stage,)))
        changed = {name.split(".")[0] for name, p in model.named_parameters()
                   if not torch.equal(p, before[name])}
        frozen[stage] = changed
        losses = histories[stage].series("loss")[1]
        assert np.isfinite(losses).all()
        assert losses[-10:].mean() < 0.8 * losses[:10].mean(), stage
    assert frozen == {"frame": {"frame"}, "sequence": {"sequence"}, "dynamics": {"dynamics"}}
    assert histories["dynamics"].series("kl_f")[1][-1] > 0


def test_generation_length_and_finiteness(prepared):
    torch.manual_seed(0)
    model = staged(DFN(SMALL), prepared.train.windows)
    prefix = prepared.test.windows[:1, :8].expand(3, -1, -1)
    motion = model.sample(prefix, 200, generator=torch.Generator().manual_seed(0))
    assert motion.shape == (3, 200, 66) and torch.isfinite(motion).all()
    assert torch.equal(motion[:, :8], prefix)                          # the prefix comes back as given
    assert not torch.allclose(motion[0, 8:], motion[1, 8:])            # stochastic
    again = model.sample(prefix, 200, generator=torch.Generator().manual_seed(0))
    assert torch.equal(motion, again)                                  # reproducible with a generator
    mean_path = model.sample(prefix, 50, temperature=0.0)
    assert torch.allclose(mean_path[0], mean_path[1])                  # temperature 0: no noise
    out = model.sample(prefix, 30, latents=True)
    assert out["z"].shape == (3, 22, SMALL.current) and out["f"].shape == (3, 22, SMALL.future)
    assert model.sample(prefix, 8).shape == (3, 8, 66)               # nothing to generate


@pytest.mark.slow
def test_trained_generation_is_stable_and_diversifies(prepared):
    """A small model trained briefly: 30 s of generated motion stays within the data's range,
    keeps moving, and samples from one prefix move apart."""
    torch.manual_seed(0)
    config = DFNConfig(frame_hidden=64, past=32, future=8, current=8, horizon=6)
    model = DFN(config)
    cfg = lambda steps: training.TrainConfig(epochs=100, max_steps=steps, batch_size=32, lr=3e-3,  # noqa: E731
                                             progress=False)
    train_stages(model, prepared, {"frame": cfg(150), "sequence": cfg(100), "dynamics": cfg(300)})
    prefix = prepared.test.windows[:1, :10].expand(8, -1, -1)
    frames = int(30 * config.fps)
    motion = model.sample(prefix, frames, generator=torch.Generator().manual_seed(0))
    features = prepared.normalizer.denormalize(motion.numpy())
    reference = prepared.normalizer.denormalize(prepared.train.windows.numpy()).reshape(-1, 66)
    assert metrics.fraction_in_range(features[:, -100:], reference).mean() > 0.9        # no explosion
    pose = features[..., rep.POSE]
    speed = metrics.frame_speed(pose, config.fps)
    data_speed = metrics.frame_speed(reference[None, :2000, rep.POSE], config.fps).mean()
    assert speed[:, -100:].mean() > 0.3 * data_speed                                     # no freezing
    spread = metrics.mean_distance_over_time(pose)[0]
    assert spread[-100:].mean() > 2 * spread[10:20].mean()                               # diversifies


def test_prior_feed_gives_the_past_state_the_priors_samples_in_training_only(prepared):
    """``prior_feed``: in training (and only there) the past GRU sometimes reads the priors'
    samples; the losses' posteriors, priors and targets are computed as before."""
    batch = prepared.train.windows[:6]
    torch.manual_seed(0)
    paper = staged(DFN(SMALL), prepared.train.windows)
    fed = staged(DFN(replace(SMALL, prior_feed=0.5)), prepared.train.windows)
    fed.load_state_dict(paper.state_dict())
    runs = {}
    for name, model in (("paper", paper), ("fed", fed)):
        for mode in ("eval", "train"):
            getattr(model, mode)()
            with torch.no_grad():
                runs[name, mode] = model.infer(batch, generator=torch.Generator().manual_seed(3))
    assert DFNConfig().prior_feed == 0.0 and DFNConfig.paper().prior_feed == 0.0          # the paper's
    for key in ("h", "qz_mu", "pf_mu", "x_hat"):
        assert torch.equal(runs["paper", "eval"][key], runs["fed", "eval"][key])      # evaluation: no feeding
        assert torch.equal(runs["paper", "eval"][key], runs["paper", "train"][key])   # 0: as the paper
    h_paper, h_fed = runs["paper", "train"]["h"], runs["fed", "train"]["h"]
    assert torch.equal(h_paper[:, 0], h_fed[:, 0])                      # h_0 is read before any feeding
    fed_first = (h_paper[:, 1] - h_fed[:, 1]).abs().amax(-1) > 1e-6    # h_1: which windows were fed at t = 0
    assert fed_first.any() and not fed_first.all()                      # per window, by chance
    assert torch.equal(runs["paper", "train"]["x"], runs["fed", "train"]["x"])        # the same targets


@pytest.mark.parametrize("call, match", [
    (lambda m, w: m.loss(w[..., :65]), "batch"),
    (lambda m, w: m.loss(w[:, :2]), "batch"),                          # shorter than the horizon
    (lambda m, w: m.sample(w[:, :8, :63], 20), "prefix"),
    (lambda m, w: m.sample(w[0, :8], 20), "prefix"),
    (lambda m, w: m.sample(w[:, :8], 5), "frames"),
    (lambda m, w: m.sample(w[:, :8], 20.0), "frames"),
    (lambda m, w: m.sample(w[:, :8], 20, temperature=-1.0), "temperature"),
    (lambda m, w: m.sample(w[:, :8], 20, temperature=math.nan), "temperature"),
    (lambda m, w: m.reconstruct(w, through="dynamics"), "through"),
    (lambda m, w: m.set_stage("everything"), "stage"),
    (lambda m, w: m.set_stage("dynamics"), "windows"),
    (lambda m, w: m.td_terms(m.infer(w), skip=0), "skip"),
    (lambda m, w: train_stages(m, w, {}, stages=("frame",)), "configs"),
    (lambda m, w: train_stages(m, w, {}, stages=("warmup",)), "stages"),
])
def test_bad_arguments_raise_value_errors(prepared, call, match):
    model = staged(DFN(SMALL), prepared.train.windows)
    with pytest.raises(ValueError, match=match):
        call(model, prepared.train.windows[:2])


# -- §5.1: the rotation decoder and its forward kinematics ----------------------------------

def test_forward_kinematics_matches_the_course_and_keeps_every_bone(prepared):
    metres = torch.as_tensor(prepared.in_data_units(prepared.train.windows)[..., rep.POSE], dtype=torch.float32)
    fk = ForwardKinematics()
    fk.fit(metres.unflatten(-1, (21, 3)))
    lengths = LOCOMOTION.bone_lengths(metres.unflatten(-1, (21, 3)).numpy()).reshape(-1, 20).mean(0)
    assert np.allclose(fk.offsets[1:].norm(dim=-1).numpy(), lengths, atol=1e-5)    # the data's mean bones
    torch.manual_seed(0)
    quaternions = torch.randn(7, len(fk.rotated), 4)
    hips = torch.randn(7, 3)
    joints = fk(quaternion_to_matrix(quaternions), hips)                            # (7, 21, 3)
    # the same as rotations.forward_kinematics with every leaf unturned
    local = np.tile(np.eye(3), (7, 21, 1, 1))
    local[:, fk.rotated] = quaternion_to_matrix(quaternions).double().numpy()
    offsets = np.broadcast_to(fk.offsets.double().numpy(), (7, 21, 3)).copy()
    offsets[:, 0] = hips.double().numpy()
    _, expected = forward_kinematics(LOCOMOTION.parents, local, offsets)
    assert np.allclose(joints.numpy(), expected, atol=1e-5)
    assert np.allclose(LOCOMOTION.bone_lengths(joints.numpy()), lengths, atol=1e-5)   # any rotation, same bones


@pytest.mark.slow
def test_rotation_decoder_is_the_default_and_cannot_stretch_bones(prepared):
    assert DFNConfig().pose_decoder == "rotations" and DFNConfig.paper().pose_decoder == "rotations"
    with pytest.raises(ValueError, match="pose_decoder"):
        DFNConfig(pose_decoder="joints")
    with pytest.raises(ValueError, match="pose_decoder"):
        DFNConfig(n_pose=72)
    torch.manual_seed(0)
    drift = {}
    for decoder in ("rotations", "positions"):
        model = DFN(replace(SMALL, pose_decoder=decoder, frame_hidden=64))
        truth = prepared.in_data_units(prepared.test.windows)
        model.normalizer = prepared.normalizer
        model.set_stage("frame", prepared.train.windows)
        before = metrics.pose_error(prepared.in_data_units(model.reconstruct(prepared.test.windows)), truth)
        train_stages(model, prepared, {"frame": training.TrainConfig(epochs=100, max_steps=200, batch_size=16,
                                                                     lr=3e-3, progress=False)}, stages=("frame",))
        decoded = prepared.in_data_units(model.reconstruct(prepared.test.windows))
        drift[decoder] = metrics.bone_length_drift(rep.to_positions(decoded, SMALL.fps))
        assert decoder == "positions" or metrics.pose_error(decoded, truth) < 0.6 * before    # it learned
    assert drift["rotations"] < 1e-5 < 1e-3 < drift["positions"]


def test_the_decoders_forward_kinematics_is_the_librarys():
    """DFN's torch layer and motionlab.rotations.forward_kinematics (numpy, every reader's)
    place every joint alike, for any rotations: one definition of FK, written twice only
    because one must carry gradients."""
    from motionlab.models.dfn import ForwardKinematics
    from motionlab.rotations import forward_kinematics
    from motionlab.skeleton import LOCOMOTION
    layer = ForwardKinematics()
    generator = torch.Generator().manual_seed(0)
    layer.offsets.copy_(0.2 * torch.randn(LOCOMOTION.n_joints, 3, generator=generator, dtype=torch.float64).float())
    q, _ = torch.linalg.qr(torch.randn(5, len(layer.rotated), 3, 3, generator=generator, dtype=torch.float64))
    hips = torch.randn(5, 3, generator=generator, dtype=torch.float64)
    ours = layer.double()(q, hips)
    local = np.tile(np.eye(3), (5, LOCOMOTION.n_joints, 1, 1))
    local[:, layer.rotated] = q.numpy()
    offsets = np.tile(layer.offsets.numpy(), (5, 1, 1))
    offsets[:, 0] = hips.numpy()
    _, theirs = forward_kinematics(np.asarray(LOCOMOTION.parents), local, offsets)
    assert np.allclose(ours.numpy(), theirs, atol=1e-12)


# -- A contact head (not in the paper): contacts drawn between the future and the current state ----

HEAD = replace(SMALL, contact_head=True)


def _headed(prepared, seed=0):
    torch.manual_seed(seed)
    model = DFN(HEAD)
    model.normalizer = prepared.normalizer            # the data's contacts are measured in metres
    return staged(model, prepared.train.windows)


def test_contact_head_config_and_where_the_contacts_enter(prepared):
    with pytest.raises(ValueError, match="contact_head"):
        DFNConfig(pose_decoder="positions", n_pose=60, contact_head=True)
    assert DFNConfig().contact_head is False and DFNConfig.paper().contact_head is False       # the paper's
    model = _headed(prepared)
    assert all(p.requires_grad for p in model.contact_head.parameters())      # trained with the dynamics
    model.set_stage("frame")
    assert not any(p.requires_grad for p in model.contact_head.parameters())
    d = model.dynamics
    h, s = torch.randn(2, HEAD.past), torch.randn(2, HEAD.summary)
    planted, lifted = torch.ones(2, 4), torch.zeros(2, 4)
    # the current prior and the past GRU read the contacts (as +-1): other contacts, other states
    assert not torch.allclose(d.current_prior(h, s, 2 * planted - 1)[0], d.current_prior(h, s, 2 * lifted - 1)[0])
    state = d.initial_state(2, HEAD.past, "cpu")
    z, f = torch.randn(2, HEAD.current), torch.randn(2, HEAD.future)
    assert not torch.allclose(d.step_past(state, z, f, planted)[-1], d.step_past(state, z, f, lifted)[-1])


def test_contact_head_loss_is_the_heads_likelihood_of_the_data_contacts(prepared):
    model = _headed(prepared)
    batch = prepared.train.windows[:6]
    torch.manual_seed(1)
    terms = model.loss(batch)
    torch.manual_seed(1)
    out = model.infer(batch)
    steps = out["z"].shape[1]
    labels = model.data_contacts(batch)[:, :steps]
    assert torch.equal(out["contacts"], labels) and 0 < labels.mean() < 1
    expected = -model.contact_head.log_prob(labels, torch.cat([out["h"], out["f"]], -1)).mean() / steps
    assert torch.allclose(terms["contacts"], expected, atol=1e-5)
    assert abs(float(terms["contacts"]) - math.log(16)) < 0.5             # untrained: about uniform
    with pytest.raises(ValueError, match="normaliser"):                 # labels in metres need it
        staged(DFN(HEAD), prepared.train.windows).loss(batch)


def test_contact_head_generates_its_contacts_reproducibly(prepared):
    model = _headed(prepared)
    prefix = prepared.normalizer.denormalize(prepared.test.windows[:2, :8].numpy())
    first = model.generate(prefix=prefix, frames=30, n=2, seed=3)
    assert first.features.shape == (2, 30, 66) and np.isfinite(first.features).all()
    assert first.contacts.shape == (2, 30, 4) and first.contacts.dtype == bool
    again = model.generate(prefix=prefix, frames=30, n=2, seed=3)
    assert np.array_equal(first.contacts, again.contacts) and np.array_equal(first.features, again.features)
    other = model.generate(prefix=prefix, frames=30, n=2, seed=4)
    assert not np.array_equal(first.contacts, other.contacts)
    out = model.sample(prepared.test.windows[:2, :8], 20, generator=torch.Generator().manual_seed(0), latents=True)
    assert out["contacts"].shape == (2, 12, 4)
    plain = staged(DFN(SMALL), prepared.train.windows)
    plain.normalizer = prepared.normalizer
    assert plain.generate(prefix=prefix, frames=5, n=2).contacts is None           # no head, nothing drawn


@pytest.mark.slow
def test_contact_head_learns_the_contacts_and_the_checkpoint_keeps_it(prepared, tmp_path):
    model = _headed(prepared)
    model.set_stage("frame")
    cfg = lambda steps: training.TrainConfig(epochs=100, max_steps=steps, batch_size=16, lr=3e-3,  # noqa: E731
                                             progress=False)
    histories = train_stages(model, prepared, {"frame": cfg(60), "sequence": cfg(40), "dynamics": cfg(150)})
    nats = histories["dynamics"].series("contacts")[1]
    assert nats[-10:].mean() < 0.6 * nats[:10].mean()
    training.save_checkpoint(tmp_path / "dfn.pt", model, data=prepared)
    loaded = training.load_checkpoint(tmp_path / "dfn.pt").model
    assert loaded.config.contact_head and loaded.contact_head is not None
    prefix = prepared.normalizer.denormalize(prepared.test.windows[:2, :8].numpy())
    assert np.array_equal(loaded.generate(prefix=prefix, frames=20, n=2, seed=0).contacts,
                          model.generate(prefix=prefix, frames=20, n=2, seed=0).contacts)
