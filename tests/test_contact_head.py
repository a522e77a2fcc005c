"""The contact head beside Glow and MoGlow: an exact p(contacts | control), and the joint likelihood."""
import itertools
import math

import numpy as np
import pytest
import torch

from motionlab import contacts, data, training
from motionlab.models.contact_head import N_CONTACTS, STATES, ContactHead, labels_of, states
from motionlab.models.glow import Glow, GlowConfig

SMALL = GlowConfig(window=16, levels=2, steps=2, hidden=16, contact_head=True)


@pytest.fixture(scope="module")
def synthetic():
    return data.prepare(data.load("synthetic", fps=20, n_clips=8, duration_s=6), window_s=0.8)


def _randomised_head(seed=0):
    torch.manual_seed(seed)
    head = ContactHead(3, hidden=8)
    with torch.no_grad():
        for p in head.parameters():
            p.add_(0.5 * torch.randn_like(p))
    return head


def test_states_and_labels_are_inverse():
    index = torch.arange(STATES)
    assert STATES == 2 ** N_CONTACTS == 16
    assert torch.equal(states(labels_of(index)), index)
    assert labels_of(torch.tensor(5)).tolist() == [1.0, 0.0, 1.0, 0.0]     # left ankle, right ankle


def test_the_head_is_a_distribution_over_every_contact_sequence():
    """Summed over all 16^2 label sequences of two frames, p(c | u) is 1: an exact likelihood."""
    head = _randomised_head()
    control = torch.randn(1, 2, 3)
    every = torch.stack([torch.stack([labels_of(torch.tensor(a)), labels_of(torch.tensor(b))])
                         for a, b in itertools.product(range(STATES), repeat=2)])
    log_p = head.log_prob(every, control.expand(len(every), -1, -1))
    assert log_p.shape == (STATES ** 2,)
    assert torch.logsumexp(log_p, 0).item() == pytest.approx(0.0, abs=1e-5)


def test_the_head_samples_labels_reproducibly_and_from_its_own_distribution():
    head = _randomised_head(1)
    control = torch.randn(1, 3, 3).expand(4000, -1, -1)
    first = head.sample(control[:5], torch.Generator().manual_seed(3))
    assert first.shape == (5, 3, N_CONTACTS) and set(first.unique().tolist()) <= {0.0, 1.0}
    assert torch.equal(first, head.sample(control[:5], torch.Generator().manual_seed(3)))
    drawn = states(head.sample(control, torch.Generator().manual_seed(0)))          # (4000, 3)
    # every 3-frame sequence's probability from log_prob, marginalised to its first and its last frame
    every = torch.tensor(list(itertools.product(range(STATES), repeat=3)))
    p = head.log_prob(labels_of(every), control[:1].expand(len(every), -1, -1)).exp().detach()
    for frame in (0, 2):
        expected = torch.zeros(STATES).index_add_(0, every[:, frame], p)
        frequency = torch.bincount(drawn[:, frame], minlength=STATES).float() / len(drawn)
        assert torch.allclose(frequency, expected, atol=0.025), frame


def test_config_refuses_a_head_it_cannot_have():
    with pytest.raises(ValueError, match="contact_head"):
        GlowConfig(contact_head=True, conditional=False)
    with pytest.raises(ValueError, match="contact_head"):
        GlowConfig(contact_head=True, n_features=20, n_control=2, constant_features=())


def test_the_joint_likelihood_is_the_flow_given_the_data_contacts_plus_the_head(synthetic):
    torch.manual_seed(0)
    model = Glow(SMALL)
    windows = synthetic.test.windows[:6]
    with pytest.raises(ValueError, match="contact_head.*normaliser"):
        model.loss(windows)
    model.normalizer = synthetic.normalizer
    labels = model.data_contacts(windows)
    assert labels.shape == (6, 16, N_CONTACTS)
    expected = contacts.contact_labels(synthetic.normalizer.denormalize(windows), 20.0)
    assert torch.equal(labels[:, :-1], expected) and torch.equal(labels[:, -1], expected[:, -1])
    x, control = model.split_features(windows)
    z, logdet = model.flow(x, torch.cat([control, 2 * labels - 1], -1))
    head = model.contact_head.log_prob(labels, control)
    joint = model.log_likelihood(windows)
    assert torch.allclose(joint, model.prior.log_prob(z) + logdet + head, atol=1e-4)
    loss = model.loss(windows)
    assert loss["contact_bits_per_frame"].item() == pytest.approx(-head.mean().item() / 16 / math.log(2), rel=1e-5)
    assert loss["loss"].item() == pytest.approx(-joint.mean().item() / (16 * model.n_modelled), rel=1e-5)
    assert model.nll_is == "bound, with contacts" and Glow(GlowConfig()).nll_is == "exact"


def test_sampling_draws_contacts_or_takes_them_and_inverts_the_flow(synthetic):
    torch.manual_seed(0)
    model = Glow(SMALL)
    model.normalizer = synthetic.normalizer
    windows = synthetic.test.windows[:4]
    model.log_likelihood(windows)                                  # ActNorm's data-dependent start
    with torch.no_grad():
        for p in model.flow.parameters():
            p.add_(0.05 * torch.randn_like(p))
    control = windows[..., -3:]
    drawn = model.sample(4, control, temperature=0.7, generator=torch.Generator().manual_seed(1))
    assert drawn.shape == windows.shape and torch.isfinite(drawn).all()
    labels = model.data_contacts(windows)
    z, _ = model.encode(windows)
    back = model.decode(z, control, contacts=labels)
    assert torch.allclose(back[..., model.modelled], windows[..., model.modelled], atol=1e-3)
    other = model.decode(z, control, contacts=1 - labels)               # the flow reads the labels
    assert (other - back).abs().max() > 1e-3
    for bad in (labels[:, :-1], labels * 0.5, labels[..., :3]):
        with pytest.raises(ValueError, match="contacts"):
            model.sample(4, control, contacts=bad)
    real = synthetic.normalizer.denormalize(windows).numpy()
    generated = model.generate(real[..., -3:], n=4, temperature=0.7, seed=5)
    again = model.sample(4, control, temperature=0.7, generator=torch.Generator().manual_seed(5))
    np.testing.assert_allclose(generated.features, synthetic.normalizer.denormalize(again).numpy(), atol=1e-4)
    assert generated.contacts.shape == (4, 16, N_CONTACTS) and generated.contacts.dtype == bool
    plain = Glow(GlowConfig(window=16, levels=2, steps=2, hidden=16))
    plain.normalizer = synthetic.normalizer
    assert plain.generate(real[..., -3:], n=4).contacts is None            # no head, nothing drawn
    with pytest.raises(ValueError, match="contacts: this Glow has no contact head"):
        Glow(GlowConfig(window=16, levels=2, steps=2, hidden=16)).sample(4, control, contacts=labels)


def test_training_learns_the_contacts_and_the_checkpoint_keeps_the_head(synthetic, tmp_path):
    torch.manual_seed(0)
    model = Glow(SMALL)
    config = training.TrainConfig(epochs=3, batch_size=16, lr=3e-3, seed=0)
    history = training.train(model, synthetic, config)
    bits = history.series("contact_bits_per_frame")[1]
    assert bits[-1] < 0.7 * bits[0]
    training.save_checkpoint(tmp_path / "glow.pt", model, data=synthetic)
    loaded = training.load_checkpoint(tmp_path / "glow.pt").model
    assert loaded.config.contact_head and loaded.contact_head is not None
    windows = synthetic.test.windows[:4]
    assert torch.allclose(loaded.log_likelihood(windows), model.eval().log_likelihood(windows), atol=1e-3)
    assert "contact_head" in loaded.describe()[-1]


# -- MoGlow: the head per frame, given the frame's conditioning, streamed with the flow ------------

from motionlab.models.moglow import MoGlow, MoGlowConfig           # noqa: E402

MOGLOW = MoGlowConfig(window=16, history=4, steps=2, hidden=16, contact_head=True)


def _moglow(synthetic):
    torch.manual_seed(0)
    model = MoGlow(MOGLOW)
    model.normalizer = synthetic.normalizer
    model.loss(synthetic.test.windows[:8])                          # ActNorm's data-dependent start
    with torch.no_grad():
        for p in list(model.flow.parameters()) + list(model.contact_head.parameters()):
            p.add_(0.05 * torch.randn_like(p))
    return model.eval()


def test_moglow_config_and_the_joint_likelihood(synthetic):
    with pytest.raises(ValueError, match="contact_head"):
        MoGlowConfig(contact_head=True, n_features=20, n_control=2, constant_features=())
    model = _moglow(synthetic)
    windows = synthetic.test.windows[:5]
    labels = model.data_contacts(windows)[:, 4:]
    poses, control = windows[..., model.modelled], windows[..., model.control]
    cond = model.conditioning(poses, control)
    z, logdet = model.flow(poses[:, 4:], torch.cat([cond, 2 * labels - 1], -1))
    expected = model.prior.log_prob(z) + logdet + model.contact_head.log_prob(labels, cond)
    assert torch.allclose(model.log_likelihood(windows), expected, atol=1e-4)
    assert model.nll_is == "bound, with contacts" and "contact_head" in model.describe()[-1]


def test_moglow_streams_its_contacts_as_the_reference_sampler_draws_them(synthetic):
    model = _moglow(synthetic)
    x = synthetic.test.windows[:3]
    history, control = x[:, :4], x[:, 4:, -3:]
    noise = torch.randn(3, 12, model.n_modelled, generator=torch.Generator().manual_seed(1))
    reference = model.sample(control, history, temperature=0.7, noise=noise, generator=torch.Generator().manual_seed(2))
    stream = model.stream(history, temperature=0.7, generator=torch.Generator().manual_seed(2))
    streamed = torch.stack([stream.step(control[:, t], noise[:, t]) for t in range(12)], dim=1)
    assert torch.allclose(streamed, reference, atol=1e-4)
    assert stream.contacts.shape == (3, N_CONTACTS) and stream.contacts.dtype == torch.bool
    assert model.stream(history).contacts is None                 # nothing drawn yet
    other = model.sample(control, history, temperature=0.7, noise=noise, generator=torch.Generator().manual_seed(3))
    assert (other - reference).abs().max() > 1e-3             # other contacts drawn: another pose
    real = synthetic.normalizer.denormalize(x).numpy()                # data units, as generate takes them
    generated = model.generate(real[:, 4:, -3:], n=3, prefix=real[:, :4], seed=0)
    assert generated.features.shape == (3, 12, 66) and np.isfinite(generated.features).all()
    assert generated.contacts.shape == (3, 12, N_CONTACTS) and generated.contacts.dtype == bool


def test_the_live_character_holds_the_contacts_its_model_drew(synthetic):
    from motionlab import live
    model = _moglow(synthetic)
    character = live.LiveCharacter(model, 20.0, seed=1)
    for _ in range(12):
        character.tick({"forward"})
        drawn = character.stream.contacts[0].numpy()
        assert (character.lock.contact[0] >= drawn).all()              # every drawn contact is held


def test_a_markov_moglow_returns_the_contacts_it_drew(synthetic):
    """A feed-forward MoGlow samples through ``sample``, not the stream: its ``generate`` keeps the drawn contacts too."""
    from dataclasses import replace
    torch.manual_seed(0)
    model = MoGlow(replace(MOGLOW, recurrent=False))
    model.normalizer = synthetic.normalizer
    model.loss(synthetic.test.windows[:8])
    model.eval()
    real = synthetic.normalizer.denormalize(synthetic.test.windows[:2]).numpy()
    generated = model.generate(real[:, 4:, -3:], n=2, prefix=real[:, :4], seed=0)
    assert generated.contacts.shape == (2, 12, N_CONTACTS) and generated.contacts.dtype == bool
    control = synthetic.test.windows[:2, 4:, -3:]
    frames, drawn = model._sample(control, synthetic.test.windows[:2, :4], 1.0, None, torch.Generator().manual_seed(5))
    again = model.sample(control, synthetic.test.windows[:2, :4], 1.0, generator=torch.Generator().manual_seed(5))
    assert torch.equal(frames, again) and drawn.shape == (2, 12, N_CONTACTS)
