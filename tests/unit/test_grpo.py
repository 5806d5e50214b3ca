"""GRPO's advantages (rlchain/algos/grpo/advantages.py) against hand-computed values, and shared starts."""

import math

import pytest
import torch

from rlchain.algos.grpo.advantages import alive_mask, discounted_returns, group_advantages, k3_kl
from rlchain.algos.grpo.shared_starts import share_group_starts, supports_shared_starts
from rlchain.envs.backends.torch_envs.point_mass import TorchPointMass

# T = 2 steps, N = 4 envs (one group), gamma 0.5; env 1's episode ends at t = 0
REWARDS = torch.tensor([[1.0, 0.0, 2.0, 1.0], [1.0, 2.0, 0.0, 0.0]])
DONES = torch.tensor([[False, True, False, False], [False, False, False, False]])


def test_discounted_returns_restart_after_done_and_do_not_bootstrap():
    returns = discounted_returns(REWARDS, DONES, 0.5)
    assert returns.tolist() == [[1.5, 0.0, 2.0, 1.0], [1.0, 2.0, 0.0, 0.0]]


def test_alive_mask_keeps_the_first_episode_including_its_last_step():
    assert alive_mask(DONES).tolist() == [[1, 1, 1, 1], [1, 0, 1, 1]]
    assert alive_mask(DONES, truncate_at_first_done=False).tolist() == [[1, 1, 1, 1]] * 2


def test_group_advantages_by_hand():
    adv = group_advantages(discounted_returns(REWARDS, DONES, 0.5), alive_mask(DONES), 4, eps=0.0)
    # step 0: returns 1.5, 0, 2, 1 -> mean 1.125, population std sqrt(0.546875)
    std0 = math.sqrt(0.546875)
    assert adv[0].tolist() == pytest.approx([0.375 / std0, -1.125 / std0, 0.875 / std0, -0.125 / std0])
    # step 1: env 1 masked; returns 1, 0, 0 -> mean 1/3, std sqrt(2/9)
    std1 = math.sqrt(2 / 9)
    assert adv[1].tolist() == pytest.approx([(2 / 3) / std1, 0.0, (-1 / 3) / std1, (-1 / 3) / std1])


def test_groups_are_contiguous_and_independent():
    returns = torch.tensor([[1.0, 3.0, 10.0, 30.0]])
    adv = group_advantages(returns, torch.ones(1, 4), 2, eps=0.0)
    assert adv.tolist() == [[-1.0, 1.0, -1.0, 1.0]]
    with pytest.raises(ValueError, match="divisible"):
        group_advantages(returns, torch.ones(1, 4), 3)


def test_per_rank_groups_give_the_advantages_of_the_whole_batch():
    """multi_gpu: each rank normalises its own envs' groups; with group_size dividing every rank's env count
    that is the whole batch's computation, split by rank."""
    torch.manual_seed(0)
    returns, dones = torch.randn(5, 16), torch.rand(5, 16) < 0.2
    mask = alive_mask(dones)
    whole = group_advantages(returns, mask, 4)
    ranks = [group_advantages(returns[:, r * 8:(r + 1) * 8], mask[:, r * 8:(r + 1) * 8], 4) for r in range(2)]
    assert torch.allclose(torch.cat(ranks, dim=1), whole)


def test_k3_kl_is_zero_at_equal_policies_and_positive_elsewhere():
    lp = torch.tensor([-1.0, -2.0])
    assert k3_kl(lp, lp).tolist() == [0.0, 0.0]
    d = 0.3
    assert k3_kl(torch.tensor([0.0]), torch.tensor([d])).item() == pytest.approx(math.exp(d) - d - 1)


def test_shared_starts_copy_each_leader_state_and_obs():
    env = TorchPointMass(6, seed=0)
    obs = env.reset(seed=1)
    assert supports_shared_starts(env)
    shared = share_group_starts(env, obs, 3)
    assert torch.equal(shared[1], obs[0]) and torch.equal(shared[5], obs[3])
    assert torch.equal(env.state[2], env.state[0]) and not torch.equal(env.state[3], env.state[0])
    a = torch.full((6, 2), 0.5)
    after = env.step(a).obs
    assert torch.equal(after[0], after[2])
