"""Learning tier (slow): the history policy (a causal transformer over the last 8 steps, network.history)
reaches 450 on masked-velocity CartPole as the LSTM does (tests/learning/test_rnn_learning.py), and plays
as well stepping its window one step at a time."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow
CONFIG = os.path.join(CONFIGS, "ppo_cartpole_masked_velocity_history.yaml")


def test_history_policy_reaches_450_on_masked_velocity_cartpole(tmp_path):
    # one torch thread: the run (and the policy it stops with) does not depend on the machine's load
    over = [f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
            "params.torch_threads=1", "params.update_threads=1"]
    result = Runner().load(CONFIG, over).train()
    assert result.mean_reward >= 450, result
    last = os.path.join(result.run_dir, "nn", "last_cartpole_masked_velocity_history.pth")
    one_thread = ["params.torch_threads=1", "params.update_threads=1"]
    played = Runner().load(CONFIG, one_thread).play(last, games=10, quiet=True)
    assert played.mean_reward >= 400, played
