"""RLlib's per-iteration multi-agent episode results (rlchain.rllib.multi_agent_window) on fake episodes."""

import math

from rlchain.rllib.multi_agent_window import IterationLog, multi_agent_metrics

MODULES = {"0": "first", "1": "second", "2": "second"}


def test_return_is_the_sum_over_agents_and_means_are_runner_means():
    runner0 = [(3.0, 4, {"0": 1.0, "1": 2.0}), (5.0, 6, {"0": 2.0, "1": 3.0})]
    runner1 = [(10.0, 8, {"0": 10.0})]
    out = multi_agent_metrics([runner0, runner1], window=100, module_of=MODULES)
    assert out["episode_return_mean"] == (4.0 + 10.0) / 2  # mean of the runners' means, not 18 / 3
    assert out["episode_len_mean"] == (5.0 + 8.0) / 2 and out["num_episodes"] == 3
    assert out["agent_episode_returns_mean"] == {"0": (1.5 + 10.0) / 2, "1": 2.5}  # runner 1 never saw agent 1
    assert out["module_episode_returns_mean"] == {"first": (1.5 + 10.0) / 2, "second": 2.5}


def test_a_module_sums_its_agents_within_an_episode_over_the_episodes_they_were_in():
    episodes = [(6.0, 3, {"1": 2.0, "2": 4.0}), (1.0, 3, {"0": 1.0}), (5.0, 3, {"0": 0.0, "1": 5.0})]
    out = multi_agent_metrics([episodes], window=100, module_of=MODULES)
    assert out["module_episode_returns_mean"] == {"second": (6.0 + 5.0) / 2, "first": 0.5}
    assert out["agent_episode_returns_mean"] == {"1": 3.5, "2": 4.0, "0": 0.5}


def test_each_runner_keeps_its_last_ceil_window_over_runners_and_none_is_nan():
    old, new = (0.0, 1, {"0": 0.0}), (9.0, 1, {"0": 9.0})
    out = multi_agent_metrics([[old] * 3 + [new] * 2, [new]], window=4, module_of=MODULES)  # 2 kept per runner
    assert out["episode_return_mean"] == 9.0 and out["agent_episode_returns_mean"] == {"0": 9.0}
    assert out["num_episodes"] == 6
    empty = multi_agent_metrics([[], []], window=100, module_of=MODULES)
    assert math.isnan(empty["episode_return_mean"]) and empty["agent_episode_returns_mean"] == {}


def test_iteration_log_counts_each_train_call_apart_and_notes_each_copys_runner():
    log = IterationLog(window=100, runners=2, envs_per_runner=2)
    copies = [log.for_copy(i) for i in range(4)]  # copies 0, 1: runner 0; copies 2, 3: runner 1
    copies[0].add(2.0, 2, {"0": 2.0})
    copies[1].add(4.0, 2, {"0": 4.0})
    copies[3].add(30.0, 2, {"0": 30.0})
    first = log.take(MODULES)
    assert first["episode_return_mean"] == (3.0 + 30.0) / 2 and first["num_episodes"] == 3
    copies[2].add(7.0, 1, {"1": 7.0})
    second = log.take(MODULES)  # only what ended since the last take
    assert second["episode_return_mean"] == 7.0 and second["num_episodes"] == 1
    assert second["module_episode_returns_mean"] == {"second": 7.0}
    assert log.finished == 4 and list(log.returns) == [2.0, 4.0, 30.0, 7.0]  # rlchain's log keeps counting
    assert math.isnan(log.take(MODULES)["episode_return_mean"])
