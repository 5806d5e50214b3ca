"""Hindsight replay through the trainer: goal envs' compute_reward (gymnasium and envpool Fetch), SAC+HER
on TestGoalReach-v0's Dict observations, and the one-line errors of bad HER settings."""

import os

import numpy as np
import pytest

from rlchain import Runner
from rlchain.algos.off_policy.her import goal_layout
from rlchain.config.errors import ConfigError
from rlchain.envs.factory import make_vec_env
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke

FETCH = os.path.join(CONFIGS, "sac_her_fetch_reach.yaml")
FETCH_PUSH = os.path.join(CONFIGS, "sac_her_fetch_push.yaml")


def test_envpool_fetch_reward_is_the_documented_fetch_reward():
    """envpool's FetchReach reward equals fetch_compute_reward(achieved goal after the step, desired goal)."""
    pytest.importorskip("envpool")
    env = make_vec_env("envpool", {"env_name": "FetchReach-v4"}, 4, 0, None)
    layout = goal_layout(env.observation_space)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    rewards, recomputed = [], []
    for _ in range(60):
        result = env.step(rng.uniform(-1, 1, (4, 4)).astype(np.float32))
        last = result.final_obs  # the obs the reward was given for (the final obs on done rows)
        rewards.append(result.reward)
        recomputed.append(env.compute_reward(last[:, layout.achieved], last[:, layout.desired]))
    env.close()
    rewards, recomputed = np.concatenate(rewards), np.concatenate(recomputed)
    assert (rewards == 0).any() and (rewards == -1).any()  # both outcomes occurred
    np.testing.assert_array_equal(rewards, recomputed)


def test_gymnasium_goal_env_compute_reward_and_sac_her_trains(tmp_path):
    env = make_vec_env("TestGoalReach-v0", {}, 2, 0, "sync")
    reward = env.compute_reward(np.array([[0.0, 0.0], [0.0, 0.0]]), np.array([[0.05, 0.0], [0.5, 0.0]]))
    np.testing.assert_array_equal(reward, [0.0, -1.0])
    env.close()
    result = Runner().load(FETCH, [
        f"params.config.train_dir={tmp_path}", "params.config.env_name=TestGoalReach-v0",
        "params.config.env_config={max_steps: 10}", "params.config.max_frames=400",
        "params.config.num_warmup_frames=100", "params.config.batch_size=32",
        "params.config.save_replay_buffer=True"]).train()
    assert result.frames == 400
    # the last checkpoint carries the HER bookkeeping with the buffer; resuming restores it
    resumed = Runner().load(FETCH, [
        f"params.config.train_dir={tmp_path}", "params.config.env_name=TestGoalReach-v0",
        "params.config.env_config={max_steps: 10}", "params.config.max_frames=600",
        "params.config.num_warmup_frames=100", "params.config.batch_size=32"]).train(
        checkpoint=os.path.join(result.run_dir, "nn", "last_fetch_reach_her.pth"))
    assert resumed.frames == 600


def test_fetch_push_benchmark_config_trains_one_epoch_with_her_updates(tmp_path):
    """sac_her_fetch_push.yaml (the benchmark config of benchmarks/peers/her_vs_sb3.py) parses and trains on
    envpool FetchPush-v4: one epoch (200 frames) with the warmup cut to 100 frames and a 32-sample batch,
    so the HER replay is sampled (relabelled with the Fetch reward) for the config's 2 updates after
    each env step from the one that reaches 100 frames (26 of the 50)."""
    pytest.importorskip("envpool")
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    result = Runner().load(FETCH_PUSH, [
        f"params.config.train_dir={tmp_path}", "params.config.max_epochs=1", "params.config.max_frames=-1",
        "params.config.num_warmup_frames=100", "params.config.batch_size=32",
        "params.config.print_stats=false"]).train()
    assert result.frames == 200 and result.epoch == 1
    events = EventAccumulator(os.path.join(result.run_dir, "summaries"))
    events.Reload()
    assert [e.value for e in events.Scalars("info/updates")] == [52.0]  # 26 steps x 2


@pytest.mark.parametrize("overrides,message", [
    (["params.config.env_name=Pendulum-v1", "params.config.env_config={}"], "hindsight replay needs Dict observations"),
    (["params.config.n_step=3"], "replay.her: hindsight replay works with n_step 1"),
    (["params.config.replay={her: {strategy: episode}}"], "replay.her.strategy: 'episode' is not one of"),
    (["params.config.replay={her: {k: 0}}"], "replay.her.k"),
])
def test_bad_her_settings_are_one_line_errors(tmp_path, overrides, message):
    with pytest.raises(ConfigError, match=message) as err:
        Runner().load(FETCH, [f"params.config.train_dir={tmp_path}", "params.config.max_frames=100",
                              *overrides]).train()
    assert "\n" not in str(err.value)
