"""Learning tier (slow): multi_discrete_a2c learns TestMultiDiscrete-v0 through the runner."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow

CONFIG = os.path.join(CONFIGS, "ppo_test_multidiscrete.yaml")


def test_multidiscrete_reaches_098(tmp_path):
    """MultiDiscrete([3, 5]). The env's other spaces learn the same run: its Dict observations flatten to the same
    numbers (tests/unit/test_envs_action_spaces.py::test_dict_observations_are_flattened_in_key_order), its
    Tuple(Discrete(3), Discrete(5)) actions (rl_games' test space) split to the same env actions
    (test_tuple_actions_are_split_for_gymnasium there) and train and play (tests/smoke/test_action_spaces_smoke.py)."""
    # bound: 20 epochs (10.2k frames), 1.5 times the slowest of seeds 5, 1, 2 (6.1k, 5.1k, 6.7k frames)
    runner = Runner().load(CONFIG, [f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
                                    "params.config.max_epochs=20"])
    result = runner.train()
    # a random policy returns about -0.6 per episode, a perfect one 1.0
    assert result.stop_reason.startswith("score_to_win"), result
    assert result.mean_reward >= 0.98, result
    played = runner.play(os.path.join(result.run_dir, "nn", "test_multidiscrete.pth"), games=50, quiet=True)
    assert played.mean_reward >= 0.98, played
