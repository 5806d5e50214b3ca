"""RLlib 2.60's evaluation checks at build time (rlchain/rllib/evaluation_settings.py): each refusal one line."""

import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.ppo import PPOConfig


def _config(**evaluation):
    return PPOConfig().environment("CartPole-v1").evaluation(**evaluation)


def test_parallel_evaluation_needs_evaluation_env_runners():
    config = _config(evaluation_parallel_to_training=True, evaluation_interval=1)
    with pytest.raises(ConfigError, match="evaluation_parallel_to_training: True needs evaluation_num_env_runners "
                                          "> 0") as err:
        config.build_algo()  # refused before any env is built, as RLlib's validate() in build_algo
    assert "\n" not in str(err.value)
    assert isinstance(err.value, ValueError)  # RLlib's is a ValueError
    _config(evaluation_parallel_to_training=True, evaluation_num_env_runners=1).validate()
    _config(evaluation_parallel_to_training=False).validate()


def test_auto_duration_needs_parallel_evaluation():
    with pytest.raises(ConfigError, match="evaluation_duration: 'auto' needs evaluation_parallel_to_training=True"):
        _config(evaluation_duration="auto").validate()
    _config(evaluation_duration="auto", evaluation_parallel_to_training=True, evaluation_num_env_runners=1).validate()


@pytest.mark.parametrize("duration", [0, -3, 2.5, "10", True])
def test_duration_is_a_whole_number(duration):
    with pytest.raises(ConfigError, match="evaluation_duration: expected a whole number > 0 or 'auto'"):
        _config(evaluation_duration=duration).validate()


def test_old_evaluation_worker_name_counts():
    _config(evaluation_parallel_to_training=True, evaluation_num_workers=2).validate()
