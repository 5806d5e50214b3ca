"""V-trace against GAE (on-policy), hand-computed clipped cases, time-outs and terminations."""

import math

import pytest
import torch

from rlchain.algos.core.returns import gae
from rlchain.algos.core.vtrace import vtrace


def _nstep_returns(rewards, values, bootstrap, gamma):
    """Plain n-step returns of one env without episode ends: sum gamma^k r + gamma^n V(s_T)."""
    out, acc = [], bootstrap
    for r in reversed(rewards):
        acc = r + gamma * acc
        out.append(acc)
    return list(reversed(out))


def test_on_policy_equals_lambda_one_returns_and_gae():
    torch.manual_seed(0)
    t, n, gamma = 7, 3, 0.97
    rewards, values = torch.randn(t, n), torch.randn(t, n)
    bootstrap = torch.randn(n)
    next_values = torch.cat([values[1:], bootstrap[None]])
    never = torch.zeros(t, n, dtype=torch.bool)
    out = vtrace(torch.zeros(t, n), rewards, values, next_values, never, never, gamma)
    for i in range(n):
        expected = _nstep_returns(rewards[:, i].tolist(), values[:, i].tolist(), bootstrap[i].item(), gamma)
        assert out.vs[:, i].tolist() == pytest.approx(expected, abs=1e-5)
    adv, returns = gae(rewards, values, next_values, never, never, gamma, 1.0)
    torch.testing.assert_close(out.vs, returns)
    torch.testing.assert_close(out.advantages, adv)
    torch.testing.assert_close(out.pg_advantages, adv)


def test_on_policy_with_episode_ends_equals_gae_and_lambda():
    torch.manual_seed(1)
    t, n, gamma, lam = 9, 4, 0.9, 0.8
    rewards, values, next_values = torch.randn(t, n, 1), torch.randn(t, n, 1), torch.randn(t, n, 1)
    dones = torch.rand(t, n) < 0.3
    terminated = dones & (torch.rand(t, n) < 0.5)
    inside = ~dones  # inside an episode V(s_{t+1}) is the next step's value
    next_values[:-1][inside[:-1]] = values[1:][inside[:-1]]
    out = vtrace(torch.zeros(t, n), rewards.squeeze(-1), values, next_values, terminated, dones, gamma,
                 lam=lam)
    adv, returns = gae(rewards.squeeze(-1), values, next_values, terminated, dones, gamma, lam)
    torch.testing.assert_close(out.vs, returns)
    assert out.vs.shape == (t, n, 1)


def test_hand_computed_clipped_rho_and_c():
    gamma = 0.9
    rewards = torch.tensor([[1.0], [1.0]])
    values = torch.tensor([[1.0], [2.0]])
    next_values = torch.tensor([[2.0], [3.0]])  # V(s_2) = 3 bootstraps the fragment
    log_rhos = torch.log(torch.tensor([[2.0], [0.5]]))
    never = torch.zeros(2, 1, dtype=torch.bool)
    out = vtrace(log_rhos, rewards, values, next_values, never, never, gamma, clip_rho=1.0, clip_c=1.0)
    # clipped rhos [1, 0.5] = cs; delta_1 = 0.5 (1 + 0.9*3 - 2) = 0.85, delta_0 = 1 (1 + 0.9*2 - 1) = 1.8
    # v_1 - V_1 = 0.85, v_0 - V_0 = 1.8 + 0.9 * 1 * 0.85 = 2.565
    assert out.vs.squeeze().tolist() == pytest.approx([3.565, 2.85])
    # q_0 - V_0 = 1 + 0.9 * v_1 - 1, q_1 - V_1 = 1 + 0.9 * 3 - 2
    assert out.advantages.squeeze().tolist() == pytest.approx([0.9 * 2.85, 1.7])
    assert out.pg_advantages.squeeze().tolist() == pytest.approx([1.0 * 2.565, 0.5 * 1.7])
    assert out.rhos.squeeze().tolist() == pytest.approx([2.0, 0.5])
    # rho-bar off, c-bar 1: the TD error of t=0 is weighted 2, the trace still clipped to 1
    out = vtrace(log_rhos, rewards, values, next_values, never, never, gamma, clip_rho=None, clip_c=1.0)
    assert out.vs.squeeze().tolist() == pytest.approx([1.0 + 3.6 + 0.9 * 0.85, 2.0 + 1.7 * 0.5])
    # c-bar 0.25 cuts the trace: v_0 - V_0 = 1.8 + 0.9 * 0.25 * 0.85
    out = vtrace(log_rhos, rewards, values, next_values, never, never, gamma, clip_rho=1.0, clip_c=0.25)
    assert out.vs[0].item() == pytest.approx(1.0 + 1.8 + 0.9 * 0.25 * 0.85)
    # a separate clip for the policy gradient
    out = vtrace(log_rhos, rewards, values, next_values, never, never, gamma, clip_pg_rho=1.5)
    assert out.pg_advantages[0].item() == pytest.approx(1.5 * 0.9 * 2.85)


def test_termination_zeroes_the_bootstrap_and_cuts_the_trace():
    gamma = 0.9
    rewards = torch.tensor([[1.0], [5.0], [1.0]])
    values = torch.tensor([[4.0], [7.0], [2.0]])
    next_values = torch.tensor([[100.0], [2.0], [3.0]])  # V(final obs) of t=0 must not count: terminal
    done = torch.tensor([[True], [False], [False]])
    log_rhos = torch.log(torch.tensor([[0.5], [3.0], [0.2]]))
    out = vtrace(log_rhos, rewards, values, next_values, done, done, gamma)
    # t=0 terminal: v_0 = V_0 + 0.5 * (1 - 4) and nothing from the next episode flows back
    assert out.vs[0].item() == pytest.approx(4.0 + 0.5 * (1.0 - 4.0))
    assert out.advantages[0].item() == pytest.approx(1.0 - 4.0)
    # the next episode is a fragment of its own: same targets as computed on it alone
    alone = vtrace(log_rhos[1:], rewards[1:], values[1:], next_values[1:], done[1:], done[1:], gamma)
    torch.testing.assert_close(out.vs[1:], alone.vs)


def test_time_out_bootstraps_from_the_final_observation():
    gamma = 0.9
    rewards = torch.tensor([[1.0], [1.0]])
    values = torch.tensor([[0.0], [0.0]])
    next_values = torch.tensor([[10.0], [10.0]])
    done = torch.tensor([[True], [False]])
    never = torch.zeros_like(done)
    log_rhos = torch.log(torch.tensor([[0.5], [2.0]]))
    out = vtrace(log_rhos, rewards, values, next_values, never, done, gamma)
    # truncated at t=0: r + gamma V(final obs), weighted by rho 0.5; no trace from t=1
    assert out.vs[0].item() == pytest.approx(0.5 * (1.0 + 9.0))
    assert out.advantages[0].item() == pytest.approx(1.0 + 9.0)
    assert out.vs[1].item() == pytest.approx(1.0 * (1.0 + 9.0))


def test_several_value_heads_and_finite():
    t, n, v = 5, 2, 3
    log_rhos = torch.randn(t, n)
    out = vtrace(log_rhos, torch.randn(t, n, v), torch.randn(t, n, v), torch.randn(t, n, v),
                 torch.zeros(t, n, dtype=torch.bool), torch.zeros(t, n, dtype=torch.bool), 0.99)
    assert out.vs.shape == out.advantages.shape == out.rhos.shape == (t, n, v)
    assert all(math.isfinite(x) for x in out.vs.flatten().tolist())
