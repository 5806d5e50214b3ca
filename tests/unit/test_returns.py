"""GAE and reward shaping against hand-computed values."""

import math

import pytest
import torch

from rlchain.algos.core.returns import gae, next_values_from_rollout, shape_rewards


def test_gae_single_env_hand_computed():
    gamma, lam = 0.9, 0.5
    rewards = torch.tensor([[1.0], [2.0], [3.0]])
    values = torch.tensor([[0.5], [1.0], [1.5]]).unsqueeze(-1)
    next_values = torch.tensor([[1.0], [1.5], [2.0]]).unsqueeze(-1)
    zeros = torch.zeros(3, 1, dtype=torch.bool)
    adv, ret = gae(rewards, values, next_values, zeros, zeros, gamma, lam)
    d = [1 + 0.9 * 1.0 - 0.5, 2 + 0.9 * 1.5 - 1.0, 3 + 0.9 * 2.0 - 1.5]
    a2 = d[2]
    a1 = d[1] + gamma * lam * a2
    a0 = d[0] + gamma * lam * a1
    assert adv.squeeze().tolist() == pytest.approx([a0, a1, a2])
    assert ret.squeeze().tolist() == pytest.approx([a0 + 0.5, a1 + 1.0, a2 + 1.5])


def test_gae_termination_vs_truncation():
    gamma, lam = 0.9, 1.0
    rewards = torch.tensor([[1.0], [1.0]])
    values = torch.zeros(2, 1, 1)
    next_values = torch.full((2, 1, 1), 10.0)
    done = torch.tensor([[True], [False]])
    # terminated at t=0: no bootstrap, and nothing flows back from t=1
    adv, _ = gae(rewards, values, next_values, done, done, gamma, lam)
    assert adv[0].item() == pytest.approx(1.0)
    # truncated at t=0: bootstrap V(final obs)=10, still nothing flows back
    adv, _ = gae(rewards, values, next_values, torch.zeros_like(done), done, gamma, lam)
    assert adv[0].item() == pytest.approx(1.0 + 0.9 * 10.0)
    assert adv[1].item() == pytest.approx(1.0 + 0.9 * 10.0)


def test_next_values_use_final_obs_at_episode_end():
    values = torch.arange(6, dtype=torch.float32).reshape(3, 2, 1)
    last = torch.tensor([[100.0], [200.0]])
    final = torch.full((3, 2, 1), -1.0)
    dones = torch.tensor([[False, True], [False, False], [False, False]])
    nv = next_values_from_rollout(values, last, final, dones)
    assert nv[:, 0, 0].tolist() == [2.0, 4.0, 100.0]
    assert nv[:, 1, 0].tolist() == [-1.0, 5.0, 200.0]


def test_reward_shaper():
    r = torch.tensor([-10.0, 0.0, 10.0])
    assert shape_rewards(r, 0.1, 1.0, -0.5, 0.5).tolist() == pytest.approx([-0.5, 0.1, 0.5])
    # log_val: log of the shaped reward, as rl_games' DefaultRewardsShaper
    assert shape_rewards(torch.tensor([0.0, 1.0]), 2.0, 1.0, 0.1, 100.0, log_val=True).tolist() == pytest.approx(
        [math.log(2.0), math.log(4.0)])


def _gae_tensor_loop(rewards, values, next_values, terminated, dones, gamma, lam):
    """GAE's recursion as one tensor op per step (the definition the CPU fast path must match bit for bit)."""
    rewards, terminated, dones = rewards.unsqueeze(-1), terminated.unsqueeze(-1), dones.unsqueeze(-1)
    deltas = rewards + gamma * next_values * (1.0 - terminated.float()) - values
    not_done = 1.0 - dones.float()
    advantages, last = torch.zeros_like(values), torch.zeros_like(values[0])
    for t in range(values.shape[0] - 1, -1, -1):
        last = deltas[t] + gamma * lam * not_done[t] * last
        advantages[t] = last
    return advantages, advantages + values


def test_gae_cpu_fast_path_is_the_tensor_loop_bit_for_bit():
    g = torch.Generator().manual_seed(0)
    T, N = 300, 3
    rewards, values, next_values = torch.randn(T, N, generator=g), torch.randn(T, N, 1, generator=g), \
        torch.randn(T, N, 1, generator=g)
    dones = torch.rand(T, N, generator=g) < 0.05
    terminated = dones & (torch.rand(T, N, generator=g) < 0.5)
    for gamma, lam in ((0.99, 1.0), (0.95, 0.5), (0.99, 0.95)):
        adv, ret = gae(rewards, values, next_values, terminated, dones, gamma, lam)
        ref_adv, ref_ret = _gae_tensor_loop(rewards, values, next_values, terminated, dones, gamma, lam)
        assert adv.dtype == torch.float32 and torch.equal(adv, ref_adv) and torch.equal(ret, ref_ret)
