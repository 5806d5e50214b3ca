"""benchmarks/tree_compare.py: medians over alternating runs, the side-by-side table, a bad revision."""

import os
import sys

import pytest

from tests.conftest import ROOT

sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
tree_compare = pytest.importorskip("tree_compare")


def row(env, env_sps, rollout_sps, train_sps, num_envs=64):
    return {"env": env, "num_envs": num_envs, "env_sps": env_sps, "rollout_sps": rollout_sps, "train_sps": train_sps}


def test_medians_are_per_case_and_per_metric():
    runs = [[row("CartPole-v1", 10, 4, 1)], [row("CartPole-v1", 30, 2, 3)], [row("CartPole-v1", 20, 9, 2)]]
    assert tree_compare.medians(runs) == {("CartPole-v1", 64): {"env_sps": 20, "rollout_sps": 4, "train_sps": 2}}


def test_table_gives_each_version_and_the_ratio_head_over_base():
    old = {("HalfCheetah-v4", 64): {"env_sps": 100.0, "rollout_sps": 50.0, "train_sps": 40.0}}
    new = {("HalfCheetah-v4", 64): {"env_sps": 100.0, "rollout_sps": 55.0, "train_sps": 30.0},
           ("Ant-v4", 64): {"env_sps": 1.0, "rollout_sps": 1.0, "train_sps": 1.0}}  # not in base: left out
    lines = tree_compare.table("abc123", new, old).splitlines()
    assert "env_sps abc123" in lines[0] and "train_sps HEAD" in lines[0]
    assert len(lines) == 3 and lines[2].split()[0] == "HalfCheetah-v4"
    assert lines[2].split()[2:] == ["100", "100", "1.000", "50", "55", "1.100", "40", "30", "0.750"]


def test_a_revision_git_does_not_know_is_a_one_line_error():
    with pytest.raises(SystemExit) as exc:
        tree_compare.add_worktree("no-such-revision-xyz")
    message = str(exc.value)
    assert message.startswith("tree_compare.py: --base no-such-revision-xyz: no worktree") and "\n" not in message
