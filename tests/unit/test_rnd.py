"""``rnd``: random network distillation (rlchain/algos/core/rnd.py) and PPO's intrinsic reward."""

import copy
from types import SimpleNamespace

import pytest
import torch

from rlchain import Runner
from rlchain.algos.core.rnd import RandomNetworkDistillation, parts_to_indices
from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt
from tests.conftest import ppo_epochs


def rnd_cfg(**changes):
    base = {"weight": 0.5, "learning_rate": 1e-2, "num_outputs": 4, "predictor_units": [16], "target_units": [16],
            "state_normalization": False, "mini_epochs": 1, "obs": None}
    return SimpleNamespace(**{**base, **changes})


def test_the_intrinsic_reward_is_the_weighted_embedding_distance():
    torch.manual_seed(0)
    rnd = RandomNetworkDistillation(3, rnd_cfg())
    obs = torch.randn(5, 3)
    expected = 0.5 * (rnd.predictor(obs) - rnd.target(obs)).pow(2).sum(1).sqrt()
    torch.testing.assert_close(rnd.reward(obs), expected)
    assert rnd.reward(obs).shape == (5,)


def test_training_the_predictor_fades_the_reward_of_seen_states_only():
    torch.manual_seed(0)
    rnd = RandomNetworkDistillation(2, rnd_cfg())
    seen, novel = torch.randn(64, 2) * 0.1, torch.randn(64, 2) * 0.1 + 4.0
    before = rnd.reward(seen).mean()
    target_before = [p.clone() for p in rnd.target.parameters()]
    for _ in range(300):
        rnd.fit(seen)
    assert rnd.reward(seen).mean() < 0.2 * before
    assert rnd.reward(novel).mean() > 3 * rnd.reward(seen).mean()
    assert all(torch.equal(a, b) for a, b in zip(target_before, rnd.target.parameters()))  # the target is fixed


def test_chosen_indices_and_the_state_normalizer():
    rnd = RandomNetworkDistillation(4, rnd_cfg(state_normalization=True), indices=parts_to_indices(["1:3"], 4))
    obs = torch.tensor([[0.0, 1.0, 2.0, 9.0], [0.0, 3.0, 6.0, -9.0]])
    rnd.observe(obs)
    torch.testing.assert_close(rnd.normalizer.running_mean, torch.tensor([2.0, 4.0], dtype=torch.float64))
    torch.testing.assert_close(rnd.state(obs), torch.tensor([[-1 / 1.01, -2 / 2.01], [1 / 1.01, 2 / 2.01]]))  # std 1, 2
    assert parts_to_indices([0, "2:"], 4) == [0, 2, 3] and parts_to_indices(None, 4) is None
    with pytest.raises(ValueError, match="out of range"):
        parts_to_indices([7], 4)


def test_ppo_adds_the_intrinsic_reward_and_trains_the_predictor(base_config, tmp_path):
    config = copy.deepcopy(base_config)
    config["params"]["config"]["rnd"] = {"weight": 0.3, "num_outputs": 4, "predictor_units": [8],
                                         "target_units": [8]}
    stats, ppo = ppo_epochs(config, [], 4, 2)
    assert stats[0]["rnd_reward"] > 0 and stats[0]["rnd_loss"] > 0
    # every stored reward is CartPole's 1 plus that step's intrinsic reward
    assert bool((ppo.storage.rewards > 1.0).all())
    assert int(ppo.rnd.normalizer.count) == 2 * 8 * 4  # each rollout step's next observations
    config["params"]["config"].update(max_epochs=1, train_dir=str(tmp_path), print_stats=False, save_best_after=0)
    result = Runner().load(config).train()
    state = ckpt.load(f"{result.run_dir}/nn/last_t.pth")
    assert "rnd" in state and "predictor.0.weight" in state["rnd"]["module"]


def test_a_bad_rnd_obs_part_names_the_key(base_config):
    config = copy.deepcopy(base_config)
    config["params"]["config"]["rnd"] = {"obs": [9]}
    with pytest.raises(ConfigError, match=r"params\.config\.rnd\.obs.*out of range"):
        ppo_epochs(config, [], 4, 1)
