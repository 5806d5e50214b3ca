"""What a time-out bootstraps (``timeout_bootstrap``): V(the true final observation), rlchain's default, or
V(the state before the last step), as rl_games adds ``gamma * V(s_t)`` to the last reward."""

import pytest
import torch

import rlchain.algos.ppo.ppo as on_policy
from rlchain import Runner
from rlchain.algos.core.returns import gae

PENDULUM = "rlchain/configs/ppo_pendulum.yaml"


def test_previous_value_bootstrap_by_hand():
    """One step that times out: r=1, V(s_t)=10, V(final obs)=4, gamma=0.9, and the episode cut there.

    final_obs: 1 + 0.9 * 4 - 10 = -5.4; previous_value: 1 + 0.9 * 10 - 10 = 0 (= r - (1 - gamma) V(s_t))."""
    rewards, values = torch.tensor([[1.0]]), torch.tensor([[[10.0]]])
    done, not_terminal = torch.tensor([[True]]), torch.tensor([[False]])
    adv_final, _ = gae(rewards, values, torch.tensor([[[4.0]]]), not_terminal, done, 0.9, 0.95)
    adv_prev, ret_prev = gae(rewards, values, values.clone(), not_terminal, done, 0.9, 0.95)
    assert adv_final.item() == pytest.approx(-5.4)
    assert adv_prev.item() == pytest.approx(0.0) and ret_prev.item() == pytest.approx(10.0)


def rollout_bootstrap(tmp_path, monkeypatch, kind):
    """(values, final_values, dones) GAE sees after one Pendulum rollout of 200 steps (every env times out at
    its last step)."""
    seen = []
    real = on_policy.next_values_from_rollout

    def capture(values, last_values, final_values, dones):
        seen.append((values.clone(), final_values.clone(), dones.clone()))
        return real(values, last_values, final_values, dones)

    monkeypatch.setattr(on_policy, "next_values_from_rollout", capture)
    Runner().load(PENDULUM, ["params.config.num_actors=2", "params.config.horizon_length=200",
                             "params.config.minibatch_size=400", "params.config.max_epochs=1",
                             f"params.config.train_dir={tmp_path}", "params.config.print_stats=False",
                             f"params.config.timeout_bootstrap={kind}"]).train()
    return seen[0]


def test_rollout_stores_the_previous_state_value_on_time_outs(tmp_path, monkeypatch):
    values, final_values, dones = rollout_bootstrap(tmp_path, monkeypatch, "previous_value")
    assert dones[-1].all() and not dones[:-1].any()  # Pendulum's 200-step limit, nothing else ends it
    assert torch.equal(final_values[-1], values[-1])
    assert not final_values[:-1].any()


def test_rollout_stores_the_final_observation_value_by_default(tmp_path, monkeypatch):
    values, final_values, dones = rollout_bootstrap(tmp_path, monkeypatch, "final_obs")
    assert dones[-1].all()
    assert final_values[-1].abs().min() > 0 and not torch.allclose(final_values[-1], values[-1])
