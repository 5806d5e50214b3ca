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
    result = train(tmp_path, "sac_pendulum.yaml")  # max_frames 20000 in the config
    assert result.frames <= 20_000
    assert result.mean_reward >= -250, result
    # deterministic play (tanh of the mean) of the last checkpoint is at least as good
    played = Runner().load(os.path.join(CONFIGS, "sac_pendulum.yaml"), ONE_THREAD).play(
        os.path.join(result.run_dir, "nn", "last_pendulum_sac.pth"), games=5, quiet=True)
    assert played.mean_reward >= -300, played


def test_dqn_cartpole_reaches_475(tmp_path):
    result = train(tmp_path, "dqn_cartpole.yaml")
    assert result.mean_reward >= 475, result
