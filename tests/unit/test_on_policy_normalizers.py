"""The PPO update trains with normalizer statistics that already include its own rollout, so the
policy the update produces is the one the next rollout acts with (folding the observations in after the
update would train each update under one normalization and act under another)."""

import pytest
import torch

from rlchain import Runner
from rlchain.algos.ppo import agent as agent_module
from rlchain.algos.ppo.agent import PPOAgent
from tests.conftest import BASE


@pytest.mark.parametrize("kind,rows_per_step", [("rl_games", 2), ("returns", 1)])
def test_update_sees_this_rollout_in_the_observation_and_value_statistics(tmp_path, monkeypatch, kind,
                                                                         rows_per_step):
    seen = []
    real_update = PPOAgent.update

    def update(self, storage, progress, obs_per_minibatch=False, bootstrap_advantages=None):
        assert not obs_per_minibatch  # obs_normalizer_update: auto with discrete actions (BASE) = rollout
        model = self.model
        rows = storage.obs.reshape(-1, storage.obs.shape[-1]).double()
        seen.append((model.running_mean_std.count.item(), model.running_mean_std.running_mean.clone(), rows.mean(0),
                     model.value_mean_std.count.item()))
        return real_update(self, storage, progress, obs_per_minibatch)

    monkeypatch.setattr(PPOAgent, "update", update)
    config = {**BASE["params"]["config"], "normalize_input": True, "normalize_value": True, "max_epochs": 2,
              "value_normalizer": kind,
              "train_dir": str(tmp_path), "print_stats": False}
    Runner().load({"params": {**BASE["params"], "config": config}}).train()
    steps = 4 * 8  # num_actors x horizon_length of BASE
    assert len(seen) == 2
    (count1, mean1, rows1, vcount1), (count2, _, _, vcount2) = seen
    assert count1 == pytest.approx(steps, abs=1e-3) and count2 == pytest.approx(2 * steps, abs=1e-3)
    assert torch.allclose(mean1, rows1, atol=1e-4)  # the first update's statistics are its rollout's
    # the value statistics fold this rollout's returns (and with rl_games' normalizer its value predictions)
    # before the update too
    per_epoch = rows_per_step * steps
    assert vcount1 == pytest.approx(per_epoch, abs=1e-3) and vcount2 == pytest.approx(2 * per_epoch, abs=1e-3)


def test_minibatch_mode_folds_each_minibatch_of_the_first_pass_just_before_its_forward_pass(tmp_path, monkeypatch):
    # obs_normalizer_update: minibatch (rl_games' timing): the update starts with last epoch's
    # statistics; minibatch k of the first mini-epoch is normalized with statistics that hold minibatches 1..k;
    # the later passes use the whole rollout's
    seen, counts = [], []
    real_loss = agent_module.ppo_loss

    def loss(model, cfg, batch, *args, **kwargs):  # the minibatch's forward pass and losses
        norm = model.running_mean_std
        seen.append((norm.count.item(), norm.running_mean.clone(), batch.obs.double().mean(0)))
        return real_loss(model, cfg, batch, *args, **kwargs)

    real_update = PPOAgent.update

    def update(self, storage, progress, obs_per_minibatch=False, bootstrap_advantages=None):
        counts.append((self.model.running_mean_std.count.item(), obs_per_minibatch))
        return real_update(self, storage, progress, obs_per_minibatch)

    monkeypatch.setattr(agent_module, "ppo_loss", loss)
    monkeypatch.setattr(PPOAgent, "update", update)
    config = {**BASE["params"]["config"], "normalize_input": True, "max_epochs": 2, "mini_epochs": 2,
              "minibatch_size": 16, "obs_normalizer_update": "minibatch", "train_dir": str(tmp_path),
              "print_stats": False}
    Runner().load({"params": {**BASE["params"], "config": config}}).train()
    steps = 4 * 8  # num_actors x horizon_length of BASE: 2 minibatches of 16
    assert [c for c, _ in counts] == pytest.approx([1e-5, steps], abs=1e-3) and all(on for _, on in counts)
    assert [c for c, _, _ in seen] == pytest.approx([16, 32, 32, 32, 48, 64, 64, 64], abs=1e-3)
    assert torch.allclose(seen[0][1], seen[0][2], atol=1e-4)  # minibatch 1 alone: its own mean



def test_auto_is_minibatch_for_continuous_actions_only():
    from rlchain.algos.ppo.ppo import obs_per_minibatch

    assert [obs_per_minibatch("auto", c) for c in (True, False)] == [True, False]
    assert [obs_per_minibatch("rollout", c) for c in (True, False)] == [False, False]
    assert [obs_per_minibatch("minibatch", c) for c in (True, False)] == [True, True]
