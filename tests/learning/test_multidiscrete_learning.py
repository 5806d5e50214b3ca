"""Learning tier (slow): multi_discrete_a2c learns TestMultiDiscrete-v0 through the runner."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow

CONFIG = os.path.join(CONFIGS, "ppo_test_multidiscrete.yaml")


@pytest.mark.parametrize("overrides", [
    [],                                                  # MultiDiscrete([3, 5])
    ["params.config.env_config.tuple_actions=True"],     # Tuple(Discrete(3), Discrete(5)), rl_games' test space
    ["params.config.env_config.dict_obs=True"],          # Dict observations, flattened by the vecenv
], ids=["multidiscrete", "tuple", "dict_obs"])
def test_multidiscrete_reaches_098(tmp_path, overrides):
    runner = Runner().load(CONFIG, [f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
                                    *overrides])
    result = runner.train()
    # a random policy returns about -0.6 per episode, a perfect one 1.0
    assert result.stop_reason.startswith("score_to_win"), result
    assert result.mean_reward >= 0.98, result
    played = runner.play(os.path.join(result.run_dir, "nn", "test_multidiscrete.pth"), games=50, quiet=True)
    assert played.mean_reward >= 0.98, played
