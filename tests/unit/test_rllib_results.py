"""One ``train()``'s result dict (rlchain/rllib/results.py): the ``env_runners`` episode results as RLlib 2.60 has
them before and after the run's first finished episode."""

import math

from rlchain.rllib.episode_window import iteration_metrics
from rlchain.rllib.results import train_result


class Report:
    mean_reward, mean_length, frames, seconds, stats = None, None, 200, 0.1, {}


def _env_runners(by_runner, games):
    return train_result(Report(), {"num_actors": 1, "horizon_length": 200}, iteration=1, time_total=0.1, games=games,
                        episode_custom={}, learner={}, episodes=iteration_metrics(by_runner, 100))["env_runners"]


def test_episode_means_are_left_out_until_an_episode_ended_then_nan_in_an_iteration_without_one():
    # RLlib 2.60 (a PPO on 450-step episodes, 200 env steps a train()): no episode_* keys in the first two
    # iterations, num_episodes 0; after the first episode an iteration that ended none reports NaN
    before = _env_runners([[]], games=0)
    assert not any(key.startswith("episode_") for key in before)
    assert (before["num_episodes"], before["num_episodes_lifetime"], before["num_env_steps_sampled"]) == (0, 0, 200)
    after = _env_runners([[]], games=1)
    assert math.isnan(after["episode_return_mean"]) and math.isnan(after["episode_len_mean"])
    assert _env_runners([[(450.0, 450)]], games=1)["episode_return_mean"] == 450.0
