"""APG's objective (rlchain/algos/apg/objective.py) by hand, and gradients through the tensor envs."""

import pytest
import torch

from rlchain.algos.apg.objective import discounted_segment_return
from rlchain.envs.backends.torch_envs.pendulum import TorchPendulum
from rlchain.envs.backends.torch_envs.point_mass import TorchPointMass


def test_discounted_segment_return_restarts_after_done():
    rewards = [torch.tensor([1.0, 1.0]), torch.tensor([2.0, 2.0]), torch.tensor([4.0, 4.0])]
    dones = [torch.tensor([False, True]), torch.tensor([False, False]), torch.tensor([False, False])]
    total, next_discount = discounted_segment_return(rewards, dones, 0.5)
    # env 0: 1 + 0.5 * 2 + 0.25 * 4 = 3; env 1: ends at t=0, so 1 + 1 * 2 + 0.5 * 4 = 5
    assert total.tolist() == [3.0, 5.0] and next_discount.tolist() == [0.125, 0.25]


@pytest.mark.parametrize("env_class", [TorchPointMass, TorchPendulum])
def test_reward_gradients_flow_back_through_several_steps(env_class):
    env = env_class(4, seed=0)
    env.reset(seed=0)
    first = torch.zeros(4, env.action_space.shape[0], requires_grad=True)
    total = 0.0
    actions = [first] + [torch.zeros_like(first) for _ in range(4)]
    for a in actions:
        total = total + env.step(a).reward.sum()
    (grad,) = torch.autograd.grad(total, first)
    assert torch.isfinite(grad).all() and grad.abs().sum() > 0
    obs = env.detach_state()
    assert not obs.requires_grad and not env.state.requires_grad


def test_point_mass_success_and_auto_reset_stay_differentiable():
    env = TorchPointMass(2, seed=0, success_threshold=10.0)  # everything is a success at once
    env.reset(seed=0)
    a = torch.zeros(2, 2, requires_grad=True)
    result = env.step(a)
    assert result.terminated.all() and result.infos["success"].all()
    result.reward.sum().backward()
    assert a.grad is not None
