"""RLlib's PPO loss options in rlchain's PPO (``kl_loss_coef``, ``kl_loss_target``, ``value_loss_clip``), with
hand-checkable numbers: the pure functions of rlchain.algos.ppo.loss and the agent's adaptive coefficient."""

import pytest
import torch

from rlchain.algos.ppo.loss import adapted_kl_coef, squared_error_clamped
from tests.unit.test_ppo_kl import _agent, _rollout_one_away


def test_squared_error_is_clamped_per_sample_to_the_limit():
    values = torch.tensor([[0.0], [3.0], [-1.0]])
    returns = torch.tensor([[1.0], [0.0], [-1.5]])
    # squared errors 1, 9, 0.25; 9 clamps to 4
    assert squared_error_clamped(values, returns, 4.0).tolist() == pytest.approx([1.0, 4.0, 0.25])


def test_a_clamped_sample_gives_no_gradient():
    values = torch.tensor([[0.0], [3.0]], requires_grad=True)
    squared_error_clamped(values, torch.zeros(2, 1), 4.0).sum().backward()
    assert values.grad.flatten().tolist() == [0.0, 0.0]  # the first is at its return, the second clamped


@pytest.mark.parametrize("kl, expected", [(0.03, 0.3), (0.004, 0.1), (0.01, 0.2), (0.02, 0.2), (0.005, 0.2)])
def test_kl_coefficient_follows_rllibs_rule(kl, expected):
    # target 0.01: above 0.02 x1.5, below 0.005 x0.5, the bounds themselves leave it
    assert adapted_kl_coef(0.2, kl, 0.01) == pytest.approx(expected)


def test_penalty_adds_coef_times_kl_and_adapts_after_the_update():
    # the stored policy is 1.0 KL away from the current one; the lr is too small to move it
    agent = _agent(kl_reference="rollout", kl_loss_coef=0.2, kl_loss_target=0.01)
    out = agent.update(_rollout_one_away(agent), progress=0.0)
    assert out["kl"] == pytest.approx(1.0, rel=1e-5)
    assert out["kl_coef"] == pytest.approx(0.3)  # 1.0 > 2 * 0.01: x1.5 once per update, not per minibatch
    assert agent.state_dict()["kl_coef"] == pytest.approx(0.3)
    fresh = _agent(kl_reference="rollout", kl_loss_coef=0.2, kl_loss_target=0.01)
    fresh.load_state_dict(agent.state_dict())
    assert fresh.kl_coef == pytest.approx(0.3)


def test_penalty_term_has_a_gradient():
    with_penalty = _agent(kl_reference="rollout", kl_loss_coef=1.0, learning_rate=1e-2, lr_schedule=None,
                          mini_epochs=1)
    without = _agent(kl_reference="rollout", learning_rate=1e-2, lr_schedule=None, mini_epochs=1)
    torch.manual_seed(0)
    a = with_penalty.update(_rollout_one_away(with_penalty), progress=0.0)
    torch.manual_seed(0)
    without.update(_rollout_one_away(without), progress=0.0)
    # same data and seed: only the KL term's gradient tells the two updates apart
    assert a["kl_coef"] == pytest.approx(1.0)
    vector = torch.nn.utils.parameters_to_vector
    assert not torch.allclose(vector(with_penalty.model.parameters()), vector(without.model.parameters()))


def test_fixed_coefficient_without_target():
    agent = _agent(kl_reference="rollout", kl_loss_coef=0.2)
    assert agent.update(_rollout_one_away(agent), progress=0.0)["kl_coef"] == pytest.approx(0.2)
