"""params.config.log_info_keys: per-epoch means of step-info keys (rlchain/envs/wrappers/info_means.py)."""

import logging

import numpy as np
import pytest
import torch

from rlchain.envs.wrappers.info_means import InfoMeans


def test_means_over_every_row_of_every_step_then_afresh():
    means = InfoMeans(["reward_box_target", "elapsed_step"])
    means.add({"reward_box_target": np.array([1.0, 3.0]), "elapsed_step": np.array([1, 1]), "env_id": [0, 1]})
    means.add({"reward_box_target": torch.tensor([5.0, float("nan")]), "elapsed_step": np.array([2, 2])})
    assert means.pop() == {"env_info/reward_box_target": pytest.approx(3.0), "env_info/elapsed_step": 1.5}
    means.add({"reward_box_target": np.array([7.0, 9.0])})  # elapsed_step missing this epoch
    assert means.pop() == {"env_info/reward_box_target": 8.0}
    assert means.pop() == {}


def test_a_key_the_env_never_reports_warns_once_with_a_suggestion(caplog):
    means = InfoMeans(["reward_box_targt", "players"])
    with caplog.at_level(logging.WARNING, logger="rlchain"):
        means.add({"reward_box_target": np.array([1.0]), "players": {"env_id": [0]}})  # players: not numeric
        assert means.pop() == {}
        means.pop()
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 2  # one per key, first epoch only
    assert "'reward_box_targt' was not a numeric key" in lines[0] and "did you mean 'reward_box_target'" in lines[0]
    assert "params.config.log_info_keys" in lines[1]


def test_no_keys_costs_nothing():
    means = InfoMeans()
    means.add({"x": np.array([1.0])})
    assert means.pop() == {} and means.keys == ()


def test_totals_of_a_runner_fold_into_the_learner():
    """APPO: each runner's InfoMeans hands (sums, counts, reported keys) over; the learner's adds them."""
    runner, learner = InfoMeans(["a", "missing"]), InfoMeans(["a", "missing"])
    runner.add({"a": np.array([1.0, 3.0]), "b": np.array([0.0, 0.0])})
    totals = runner.totals()
    assert totals == ({"a": 4.0, "missing": 0.0}, {"a": 2, "missing": 0}, {"a", "b"})
    assert runner.totals()[1] == {"a": 0, "missing": 0}  # started afresh
    learner.add_totals(*totals)
    learner.add_totals({"a": 2.0}, {"a": 1}, {"a"})
    assert learner.pop() == {"env_info/a": 2.0}
