"""The PPO update trains with normalizer statistics that already include its own rollout, so the
policy the update produces is the one the next rollout acts with (before this, the observations were
folded in after the update: each update trained under one normalization and acted under another)."""

import pytest
import torch

from rlchain import Runner
from rlchain.algos.ppo.agent import PPOAgent
from tests.conftest import BASE


@pytest.mark.parametrize("kind,rows_per_step", [("rl_games", 2), ("returns", 1)])
def test_update_sees_this_rollout_in_the_observation_and_value_statistics(tmp_path, monkeypatch, kind,
                                                                         rows_per_step):
    seen = []
    real_update = PPOAgent.update

    def update(self, storage, progress):
        model = self.model
        rows = storage.obs.reshape(-1, storage.obs.shape[-1]).double()
        seen.append((model.obs_norm.count.item(), model.obs_norm.mean.clone(), rows.mean(0),
                     model.value_norm.count.item()))
        return real_update(self, storage, progress)

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
    # the value statistics fold this rollout's returns (and with rl_games' normalizer its value predictions,
    # issue 32) before the update too
    per_epoch = rows_per_step * steps
    assert vcount1 == pytest.approx(per_epoch, abs=1e-3) and vcount2 == pytest.approx(2 * per_epoch, abs=1e-3)
