"""Multi-discrete and masked configs for a couple of epochs: train (sync and async envs) -> play."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke


def small(tmp_path, *extra):
    return [f"params.config.train_dir={tmp_path}/runs", "params.config.max_epochs=2", "params.config.save_best_after=0",
            "params.config.score_to_win=100", "params.config.print_stats=false", *extra]


@pytest.mark.timeout(120)
@pytest.mark.parametrize("config,extra", [
    ("ppo_test_masked.yaml", ["params.config.vecenv_type=async", "params.config.num_actors=4",
                              "params.config.minibatch_size=64"]),
    ("ppo_test_masked.yaml", []),
    ("ppo_test_multidiscrete.yaml", ["params.config.env_config.tuple_actions=True"]),
], ids=["masked_async", "masked_sync", "tuple"])
def test_trains_and_plays(tmp_path, config, extra):
    runner = Runner().load(os.path.join(CONFIGS, config), small(tmp_path, *extra))
    result = runner.train()
    assert result.epoch == 2, result
    name = runner.params.config.name
    played = runner.play(os.path.join(result.run_dir, "nn", f"last_{name}.pth"), games=3, quiet=True)
    assert played.games == 3
    if runner.params.config.use_action_masks:  # an episode that breaks a mask ends before max_steps
        assert played.mean_length == 10.0, played
