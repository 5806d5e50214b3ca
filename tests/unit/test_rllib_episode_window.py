"""RLlib's per-iteration episode results (rlchain.rllib.episode_window) on fake streams of episodes."""

import math
from collections import deque

import torch

from rlchain.rllib.episode_window import IterationEpisodes, iteration_metrics


def test_mean_of_runner_means_not_pooled_mean():
    out = iteration_metrics([[(10.0, 10), (20.0, 20), (30.0, 30)], [(100.0, 100)]], window=100)
    assert out["episode_return_mean"] == 60.0  # (20 + 100) / 2, not 160 / 4
    assert out["episode_len_mean"] == 60.0
    assert (out["episode_return_min"], out["episode_return_max"], out["num_episodes"]) == (10.0, 100.0, 4)


def test_each_runner_keeps_its_last_ceil_window_over_runners():
    first = [(1.0, 1)] * 40 + [(5.0, 5)] * 50
    out = iteration_metrics([first, [(5.0, 5)]], window=100)  # 50 kept per runner: the 1.0s fall out
    assert out["episode_return_mean"] == 5.0
    assert out["num_episodes"] == 91  # every episode of the iteration is counted
    assert iteration_metrics([[(1.0, 1), (3.0, 3)]], window=1)["episode_return_mean"] == 3.0


def test_runner_without_episodes_left_out_and_none_is_nan():
    assert iteration_metrics([[], [(7.0, 7)]], window=100)["episode_return_mean"] == 7.0
    out = iteration_metrics([[], []], window=100)
    assert math.isnan(out["episode_return_mean"]) and math.isnan(out["episode_return_min"])
    assert out["num_episodes"] == 0


class _Tracker:
    """The two things IterationEpisodes reads from rlchain's EpisodeTracker."""

    def __init__(self) -> None:
        self.finished_returns, self.finished_lengths, self.games = deque(maxlen=100), deque(maxlen=100), 0

    def finish(self, returns):
        for r in returns:
            self.finished_returns.append(float(r))
            self.finished_lengths.append(int(r))
        self.games += len(returns)


class _Ctx:
    def __init__(self, tracker):
        self.episode_tracker = tracker


def test_episodes_of_one_iteration_only_by_runner():
    tracker = _Tracker()
    window = IterationEpisodes(runners=2, envs_per_runner=2, window=100)  # envs 0,1: runner 0; envs 2,3: runner 1
    ctx, none = _Ctx(tracker), torch.zeros(0, dtype=torch.long)
    window.on_env_step(ctx, None, none, slice(None))
    tracker.finish([10, 30])  # envs 1 and 2 end at the same step
    window.on_env_step(ctx, None, torch.tensor([1, 2]), slice(None))
    tracker.finish([50])  # env 3 (a pipelined rollout's second group: rows 2..3)
    window.on_env_step(ctx, None, torch.tensor([1]), slice(2, 4))
    first = window.take(tracker)
    assert first["episode_return_mean"] == (10 + (30 + 50) / 2) / 2
    assert first["num_episodes"] == 3
    tracker.finish([400])
    window.on_env_step(ctx, None, torch.tensor([0]), slice(None))
    assert window.take(tracker)["episode_return_mean"] == 400.0  # the earlier iteration's episodes are gone
    assert math.isnan(window.take(tracker)["episode_return_mean"])


def test_one_runner_reads_the_tracker_games_since_the_last_take():
    tracker = _Tracker()
    window = IterationEpisodes(runners=1, envs_per_runner=4, window=100)
    tracker.finish(range(1, 151))  # more than the tracker keeps: its last 100 are what can be read
    out = window.take(tracker)
    assert (out["episode_return_mean"], out["num_episodes"]) == (sum(range(51, 151)) / 100, 150)
    tracker.finish([7, 9])
    out = window.take(tracker)
    assert (out["episode_return_mean"], out["num_episodes"]) == (8.0, 2)
    tracker.games = 1000  # a restored checkpoint's count
    window.sync(tracker)
    assert math.isnan(window.take(tracker)["episode_return_mean"])
