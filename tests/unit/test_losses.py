"""PPO loss terms, distributions and schedules against hand-computed values."""

import math

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.algos.core.losses import normalize_advantages, policy_loss, smooth_clamp, value_loss
from rlchain.algos.core.schedules import AdaptiveKLSchedule, LinearSchedule
from rlchain.models.distributions import Categorical, DiagGaussian, make_distribution


def test_policy_loss_clips():
    old = torch.zeros(2)
    new = torch.log(torch.tensor([1.5, 0.5]))
    adv = torch.tensor([1.0, -1.0])
    loss = policy_loss(old, new, adv, 0.2)
    # positive advantage: ratio 1.5 clipped to 1.2 -> max(-1.5, -1.2) = -1.2
    # negative advantage: ratio 0.5 clipped to 0.8 -> max(0.5, 0.8) = 0.8
    assert loss.tolist() == pytest.approx([-1.2, 0.8])


def test_smooth_clamp_inside_and_bounds():
    x = torch.tensor([1.0, 5.0, -5.0])
    y = smooth_clamp(x, 0.8, 1.2)
    assert y[0].item() == pytest.approx(1.0)
    assert 1.19 < y[1].item() <= 1.2 + 1e-6 and 0.8 - 1e-6 <= y[2].item() < 0.81


def test_value_loss_clipped():
    v = torch.tensor([[2.0]])
    old = torch.tensor([[0.0]])
    ret = torch.tensor([[1.0]])
    assert value_loss(v, old, ret, 0.2, False).item() == pytest.approx(1.0)
    # clipped value 0.2 -> (0.2 - 1)^2 = 0.64; max(1.0, 0.64) = 1.0
    assert value_loss(v, old, ret, 0.2, True).item() == pytest.approx(1.0)
    v = torch.tensor([[1.0]])
    old = torch.tensor([[3.0]])
    ret = torch.tensor([[1.0]])
    # unclipped 0; clipped 2.8 -> 3.24
    assert value_loss(v, old, ret, 0.2, True).item() == pytest.approx(3.24)


def test_normalize_advantages():
    a = normalize_advantages(torch.tensor([1.0, 2.0, 3.0]))
    assert a.mean().item() == pytest.approx(0.0, abs=1e-6)
    assert a.std().item() == pytest.approx(1.0, abs=1e-5)


def test_categorical_matches_torch():
    logits = torch.randn(5, 3)
    d = Categorical(3)
    ref = torch.distributions.Categorical(logits=logits)
    actions = d.sample(logits)
    assert torch.allclose(d.log_prob(logits, actions), ref.log_prob(actions), atol=1e-6)
    assert torch.allclose(d.entropy(logits), ref.entropy(), atol=1e-6)
    other = torch.randn(5, 3)
    ref_kl = torch.distributions.kl_divergence(ref, torch.distributions.Categorical(logits=other))
    assert torch.allclose(d.kl(logits, other), ref_kl, atol=1e-6)


def test_categorical_sampling_frequencies():
    torch.manual_seed(0)
    logits = torch.log(torch.tensor([[0.2, 0.8]])).expand(20000, 2)
    freq = Categorical(2).sample(logits).float().mean().item()
    assert freq == pytest.approx(0.8, abs=0.02)


def test_gaussian_matches_torch_and_bounds():
    space = gym.spaces.Box(-2.0, 2.0, (2,), np.float32)
    d = DiagGaussian(space, sigma_is_logstd=True, clip_actions=True)
    mu, std = torch.randn(4, 2), torch.rand(4, 2) + 0.1
    params = torch.cat([mu, std], -1)
    ref = torch.distributions.Normal(mu, std)
    a = d.sample(params)
    assert torch.allclose(d.log_prob(params, a), ref.log_prob(a).sum(-1), atol=1e-5)
    assert torch.allclose(d.entropy(params), ref.entropy().sum(-1), atol=1e-5)
    other = torch.cat([torch.randn(4, 2), torch.rand(4, 2) + 0.1], -1)
    ref_kl = torch.distributions.kl_divergence(ref, torch.distributions.Normal(other[:, :2], other[:, 2:]))
    assert torch.allclose(d.kl(params, other), ref_kl.sum(-1), atol=1e-5)
    assert d.to_env(torch.tensor([[-5.0, 0.5]]))[0].tolist() == pytest.approx([-2.0, 1.0])
    b = d.bounds_loss(torch.tensor([[1.2, -1.3, 0.0, 0.0]]), "bound")
    assert b.item() == pytest.approx(0.1 ** 2 + 0.2 ** 2)
    r = d.bounds_loss(torch.tensor([[1.0, -2.0, 0.0, 0.0]]), "regularisation")
    assert r.item() == pytest.approx(5.0)


def test_model_preset_mismatch_message():
    with pytest.raises(ValueError, match="use discrete_a2c"):
        make_distribution("continuous_a2c_logstd", gym.spaces.Discrete(2), True)
    with pytest.raises(ValueError, match="use continuous_a2c_logstd"):
        make_distribution("discrete_a2c", gym.spaces.Box(-1, 1, (1,)), True)


def test_adaptive_kl_schedule():
    s = AdaptiveKLSchedule(0.01, min_lr=1e-6, max_lr=1e-2)
    assert s.update(1e-3, kl=0.03) == pytest.approx(1e-3 / 1.5)
    assert s.update(1e-3, kl=0.001) == pytest.approx(1.5e-3)
    assert s.update(1e-3, kl=0.01) == pytest.approx(1e-3)
    assert s.update(1e-2, kl=0.0) == pytest.approx(1e-2)


def test_linear_schedule():
    s = LinearSchedule(1e-3, 0.0)
    assert s.update(1e-3, progress=0.5) == pytest.approx(5e-4)
    assert s.update(1e-3, progress=2.0) == pytest.approx(0.0)
    assert not math.isnan(s.update(1e-3, progress=0.0))


def test_log_prob_and_entropy_agree_with_separate_calls():
    logits = torch.randn(6, 4)
    actions = torch.randint(0, 4, (6,))
    d = Categorical(4)
    lp, ent = d.log_prob_and_entropy(logits, actions)
    assert torch.allclose(lp, d.log_prob(logits, actions)) and torch.allclose(ent, d.entropy(logits))
