"""Learning tier (slow): use_action_masks on TestMaskedActions-v0, where breaking a mask ends the episode."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow

CONFIG = os.path.join(CONFIGS, "ppo_test_masked.yaml")
DISCRETE = ["params.model.name=discrete_a2c", "params.network.space={discrete: null}",
            "params.config.env_config.multi_discrete=False"]


def load(tmp_path, *overrides):
    return Runner().load(CONFIG, [f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
                                  *overrides])


@pytest.mark.parametrize("overrides", [[], DISCRETE], ids=["multidiscrete_4_3", "discrete_6"])
def test_masked_policy_reaches_085_and_plays_within_masks(tmp_path, overrides):
    # bound: 17 epochs (8.7k frames), 1.5 times the slowest of seeds 5, 1, 2 (multidiscrete 5.1k, 5.6k, 5.6k;
    # discrete 4.6k, 4.6k, 3.6k)
    runner = load(tmp_path, "params.config.max_epochs=17", *overrides)
    result = runner.train()
    # best possible mean return 0.875; a uniform choice among the allowed actions gets about 0.70
    assert result.stop_reason.startswith("score_to_win") and result.mean_reward >= 0.85, result
    name = "test_masked.pth"
    played = runner.play(os.path.join(result.run_dir, "nn", name), games=40, quiet=True)
    # an episode that breaks a mask ends early: full-length episodes mean the masks were respected
    assert played.mean_length == 10.0 and played.mean_reward >= 0.85, played


def test_without_masks_the_same_config_fails(tmp_path):
    result = load(tmp_path, "params.config.use_action_masks=False", "params.config.max_epochs=30").train()
    assert result.mean_reward < 0.3, result
