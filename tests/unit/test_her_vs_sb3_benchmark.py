"""benchmarks/her_vs_sb3.py and sb3_her_driver.py: the YAML copy each run trains, the table's pure
functions, the SB3 side's Fetch reward and its hyperparameters read from rlchain's YAML."""

import os
import sys

import numpy as np
import pytest
import yaml

from rlchain.envs.wrappers.goal_env import fetch_compute_reward
from tests.conftest import CONFIGS, ROOT

sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
her_vs_sb3 = pytest.importorskip("her_vs_sb3")
driver = pytest.importorskip("sb3_her_driver")

# (seconds from start, frames, success rate)
FAST = [(10.0, 200, 0.0), (20.0, 400, 0.5), (30.0, 600, 0.9)]
SLOW = [(20.0, 200, 0.0), (40.0, 400, 0.1), (60.0, 600, 0.8)]


def test_first_reach_is_the_first_report_at_or_above_the_target():
    assert her_vs_sb3.first_reach(FAST, 0.5) == (20.0, 400)
    assert her_vs_sb3.first_reach(SLOW, 0.8) == (60.0, 600)
    assert her_vs_sb3.first_reach(SLOW, 0.9) is None


def test_run_config_sets_seeds_and_budget_turns_success_to_win_off_and_nothing_else(tmp_path):
    path = os.path.join(CONFIGS, "sac_her_fetch_reach.yaml")
    out = her_vs_sb3.run_config(path, 7, 3000, str(tmp_path))
    with open(path) as f:
        before = yaml.safe_load(f)
    with open(out) as f:
        after = yaml.safe_load(f)
    assert after["params"]["seed"] == 7 and after["params"]["config"]["env_config"]["seed"] == 7
    assert after["params"]["config"]["max_frames"] == 3000 and "success_to_win" not in after["params"]["config"]
    for cfg in (before, after):
        cfg["params"].pop("seed")
        for key in ("env_config", "max_frames", "success_to_win"):
            cfg["params"]["config"].pop(key, None)
    assert before == after


def test_summarise_reports_success_at_fixed_frames_and_the_frames_to_the_target():
    runs = {"rlchain": [{"seed": 0, "events": FAST}], "sb3": [{"seed": 0, "events": SLOW}]}
    text = "\n".join(her_vs_sb3.summarise("reach", runs, 0.8, points=4))
    assert "| success at 450 frames | 0.50 +- 0.00 | 0.10 +- 0.00 | 5.00x |" in text
    assert "| frames to success 0.8 (seeds there: rlchain 1/1, sb3 1/1) | 600 +- 0 | 600 +- 0 | 1.00x |" in text
    assert "| frames/s (from process start) | 20.0 +- 0.0 | 10.0 +- 0.0 | 2.00x |" in text
    assert "| seconds to the first report (one epoch) | 10.0 +- 0.0 | 20.0 +- 0.0 | 0.50x |" in text


@pytest.mark.parametrize("reward_type", ["sparse", "dense"])
def test_the_sb3_side_computes_rlchains_fetch_reward(reward_type):
    rng = np.random.default_rng(0)
    achieved, desired = rng.normal(0, 0.05, (64, 3)), rng.normal(0, 0.05, (64, 3))
    theirs = driver.fetch_reward(achieved, desired, 0.05, reward_type)
    ours = fetch_compute_reward(achieved, desired, None, 0.05, reward_type)
    np.testing.assert_array_equal(theirs, ours)
    assert reward_type == "dense" or {0.0, -1.0} == set(theirs.tolist())


def test_sb3_hyperparameters_are_read_from_the_rlchain_yaml():
    pytest.importorskip("torch")
    push = driver.sb3_kwargs(driver.load_rlchain_yaml(os.path.join(CONFIGS, "sac_her_fetch_push.yaml")))
    assert push["task"] == "FetchPush-v4" and push["env_kwargs"] == {}
    assert (push["n_envs"], push["learning_rate"], push["batch_size"], push["buffer_size"]) == (4, 1e-3, 256, 1_000_000)
    assert (push["gamma"], push["tau"], push["learning_starts"], push["gradient_steps"]) == (0.98, 0.05, 2000, 2)
    assert (push["ent_coef"], push["net_arch"], push["n_sampled_goal"]) == ("auto_0.1", [256, 256], 4)
    assert (push["goal_selection_strategy"], push["window"], push["log_every"]) == ("future", 40, 200)
    assert push["normalize_input"] and push["target_entropy"] == "auto"


def test_sb3_side_refuses_what_sb3_cannot_match():
    params = driver.load_rlchain_yaml(os.path.join(CONFIGS, "sac_her_fetch_reach.yaml"))
    params["config"]["critic_lr"] = 3e-4
    with pytest.raises(SystemExit, match="one learning rate"):
        driver.sb3_kwargs(params)
    with pytest.raises(SystemExit, match="expected algo sac with replay.her"):
        driver.load_rlchain_yaml(os.path.join(CONFIGS, "sac_pendulum.yaml"))
