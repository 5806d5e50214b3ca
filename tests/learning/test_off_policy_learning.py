"""Learning tier (slow): the shipped SAC and DQN configs reach their scores on CPU."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow


ONE_THREAD = ["params.torch_threads=1", "params.update_threads=1"]
"""One torch thread: the run, and the policy it stops with, do not depend on the machine's load."""


def train(tmp_path, config, *extra):
    overrides = [f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false", *ONE_THREAD, *extra]
    return Runner().load(os.path.join(CONFIGS, config), overrides).train()


def test_sac_pendulum_reaches_minus_250_within_20k_steps(tmp_path):
    """sac_pendulum.yaml (max_frames 20000) stopped at its score_to_win -250 over the last 8 games instead of its 20:
    its 4 envs end their 200-step games together, so 20 games are the last 5 rounds (4,000 frames), and their mean
    passes -250 well after the policy does; 8 are the last 2 rounds. Random play: about -1,200."""
    result = train(tmp_path, "sac_pendulum.yaml", "params.config.games_to_track=8")
    assert result.frames <= 20_000
    assert result.mean_reward >= -250, result
    # deterministic play (tanh of the mean) of the last checkpoint is at least as good
    played = Runner().load(os.path.join(CONFIGS, "sac_pendulum.yaml"), ONE_THREAD).play(
        os.path.join(result.run_dir, "nn", "last_pendulum_sac.pth"), games=5, quiet=True)
    assert played.mean_reward >= -300, played


def test_dqn_cartpole_reaches_200(tmp_path):
    """dqn_cartpole.yaml stopped at a mean of 200 over its last 20 training games (still exploring: epsilon decays
    over the first 20k frames) instead of its 475. Random play averages about 22, so 200 is a DQN that learned, at
    under half the frames of 475 (seed 5: 200 at 19.2k frames, 475 at 45.6k; seeds 1, 2: 200 at 35.6k, 17.6k).
    The bound is 1.5 times the slowest of those seeds. The greedy policy it stopped with then plays 10 fresh games
    (those seeds: 244, 195, 328)."""
    result = train(tmp_path, "dqn_cartpole.yaml", "params.config.score_to_win=200", "params.config.max_frames=54000")
    assert result.mean_reward >= 200, result
    played = Runner().load(os.path.join(CONFIGS, "dqn_cartpole.yaml"), ONE_THREAD).play(
        os.path.join(result.run_dir, "nn", "last_cartpole_dqn.pth"), games=10, quiet=True)
    assert played.mean_reward >= 120, played


def test_sac_cartpole_reaches_150_on_discrete_actions(tmp_path):
    """sac_cartpole.yaml (SAC on Discrete actions: expectations over a categorical policy) stopped at a mean of 150
    over its last 20 training games, the policy still sampling its actions; random play averages about 22. Seeds
    5, 1, 2, 3 stopped at 5.4k, 5.6k, 5.8k, 6.0k env steps after 8.8-9.9 s of CPU on one thread; the bound is twice
    the slowest. The greedy policy it stopped with then plays 5 fresh games (those seeds, 10 games: 322, 383, 327,
    308)."""
    result = train(tmp_path, "sac_cartpole.yaml", "params.config.score_to_win=150", "params.config.max_frames=12000")
    assert result.mean_reward >= 150, result
    played = Runner().load(os.path.join(CONFIGS, "sac_cartpole.yaml"), ONE_THREAD).play(
        os.path.join(result.run_dir, "nn", "last_cartpole_sac.pth"), games=5, quiet=True)
    assert played.mean_reward >= 200, played
