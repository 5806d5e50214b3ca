"""Task success from step infos (envs/wrappers/success.py) and the success rate of tracked episodes
(training/episodes.py)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from rlchain.algos.base.episodes import EpisodeTracker
from rlchain.envs.wrappers.success import SuccessReader, resolve_key, step_success

NAN = float("nan")


def test_resolve_key_auto_prefers_success_then_is_success():
    assert resolve_key("auto", {"success": np.zeros(2), "is_success": np.zeros(2)}) == "success"
    assert resolve_key("auto", {"is_success": np.zeros(2)}) == "is_success"
    assert resolve_key("auto", {"final_info": {"is_success": np.zeros(2)}}) == "is_success"
    assert resolve_key("auto", {"reward_dist": np.zeros(2)}) is None
    assert resolve_key("goal_reached", {}) == "goal_reached"
    assert resolve_key("none", {"success": np.zeros(2)}) is None


def test_step_success_envpool_layout():
    """envpool: infos[key] at the step that ended the episode is that episode's last value."""
    infos = {"success": np.array([0.0, 1.0, 1.0]), "env_id": np.arange(3)}
    values = step_success(infos, "success", np.array([False, True, False]))
    np.testing.assert_array_equal(values, [0.0, 1.0, 1.0])


def test_step_success_gymnasium_final_info_and_masks():
    """gymnasium same-step reset: finished rows read final_info; rows without the key are NaN."""
    infos = {
        "is_success": np.array([1.0, 0.0, 0.0]), "_is_success": np.array([True, True, False]),
        "final_info": {"is_success": np.array([0.0, 1.0, 0.0]), "_is_success": np.array([False, True, False])},
    }
    values = step_success(infos, "is_success", np.array([False, True, False]))
    np.testing.assert_array_equal(values[:2], [1.0, 1.0])  # row 0 from infos, row 1 from final_info
    assert np.isnan(values[2])
    # a finished row whose final step has no value is NaN, not its reset's info
    infos = {"is_success": np.array([1.0, 1.0]), "final_info": {"other": np.ones(2)}}
    values = step_success(infos, "is_success", np.array([True, False]))
    assert np.isnan(values[0]) and values[1] == 1.0


def test_step_success_absent_or_wrong_shape_is_none():
    assert step_success({"reward": np.ones(2)}, "success", np.zeros(2, bool)) is None
    assert step_success({"success": np.ones(3)}, "success", np.zeros(2, bool)) is None  # per agent, not per row
    assert SuccessReader("auto").read({"x": 1}, np.zeros(2, bool)) is None
    assert SuccessReader("off").read({"success": np.ones(2)}, np.zeros(2, bool)) is None


def _run(tracker, steps):
    """Feed (success values, dones) per step for 2 envs with reward 1."""
    for values, dones in steps:
        tracker.step(torch.ones(2), torch.tensor(dones), success=None if values is None else np.array(values))


@pytest.mark.parametrize("mode,expected", [("any", [1.0, 0.0, 1.0]), ("last", [0.0, 0.0, 1.0])])
def test_tracker_success_any_vs_last(mode, expected):
    """env 0: success at step 1 then lost by its end (step 3); env 1: never, then next episode succeeds at its end."""
    tracker = EpisodeTracker(2, 10, torch.device("cpu"), success_mode=mode)
    _run(tracker, [([1.0, 0.0], [False, False]),
                   ([0.0, 0.0], [False, True]),   # env 1 ends without success
                   ([0.0, 1.0], [True, True])])   # env 0 ends (mode decides), env 1's 1-step episode succeeds
    assert list(tracker.finished_successes) == [0.0] + ([1.0, 1.0] if mode == "any" else [0.0, 1.0])
    assert tracker.success_rate() == pytest.approx(sum(expected) / 3)


def test_tracker_no_success_values_no_rate_and_reset_state():
    tracker = EpisodeTracker(2, 10, torch.device("cpu"))
    _run(tracker, [(None, [True, True])])
    assert tracker.has_data and not tracker.has_success
    # NaN rows carry no value: an episode that never reported one is not counted
    _run(tracker, [([NAN, 1.0], [False, False]), ([NAN, NAN], [True, True])])
    assert list(tracker.finished_successes) == [1.0]
    state = tracker.state_dict()
    fresh = EpisodeTracker(2, 10, torch.device("cpu"))
    fresh.load_state_dict(state)
    assert list(fresh.finished_successes) == [1.0]
    del state["successes"]  # a checkpoint from before success rates
    fresh.load_state_dict(state)
    assert not fresh.has_success


def test_tracker_rows_and_dropped_episodes():
    """A pipelined group's rows; a dropped (Ray-cut) episode's success is forgotten."""
    tracker = EpisodeTracker(4, 10, torch.device("cpu"))
    tracker.step(torch.ones(2), torch.tensor([False, False]), rows=slice(2, 4), success=np.array([1.0, 1.0]))
    tracker.step(torch.ones(2), torch.tensor([True, True]), rows=slice(2, 4), success=np.array([0.0, 0.0]),
                 dropped=np.array([True, False]))
    assert list(tracker.finished_successes) == [1.0]  # row 3 only; row 2 was dropped
    assert not tracker.success_seen.any()


def test_tracker_games_to_track_window():
    tracker = EpisodeTracker(1, 2, torch.device("cpu"))
    for value in (1.0, 0.0, 0.0):
        tracker.step(torch.ones(1), torch.tensor([True]), success=np.array([value]))
    assert tracker.success_rate() == 0.0


class _Step:
    def __init__(self, success, done):
        self.infos = {"success": np.array(success, dtype=np.float64)}
        self.done = np.array(done, dtype=bool)


@pytest.mark.parametrize("mode,expected", [("any", [1.0, 0.0]), ("last", [0.0, 0.0])])
def test_appo_runner_episode_success_any_vs_last(mode, expected):
    """An APPO runner tracks success per episode by hand-made steps: env 0 succeeds at step 1 only, env 1
    never; env 2 reports nothing. The learner's tracker picks any / last with its success_mode."""
    from rlchain.algos.appo.fragments import FragmentRunner
    from rlchain.envs.ray.ray_worker import EnvRecipe

    runner = FragmentRunner(EnvRecipe("x", {}, "sync"), worker=0, start=0, num_envs=3, horizon=3)
    returns, lengths, successes = [], [], []
    steps = [([1.0, 0.0, np.nan], [False, False, False]), ([0.0, 0.0, np.nan], [True, True, True])]
    for success, done in steps:
        step = _Step(success, done)
        runner._track(step, np.zeros(3, np.float32), step.done, returns, lengths, successes)
    assert successes == [(True, False), (False, False), None] and lengths == [2, 2, 2]
    tracker = EpisodeTracker(3, 10, torch.device("cpu"), mode)
    tracker.record(returns, lengths, successes)
    assert list(tracker.finished_successes) == expected and tracker.games == 3
    tracker.record([1.0], [4])  # games without success values (older fragments): no rate change
    assert list(tracker.finished_successes) == expected
