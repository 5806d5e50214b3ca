"""Learning tier (slow): the history policy (a causal transformer over the last 8 steps, network.history)
reaches 400 on masked-velocity CartPole, as the LSTM config reaches 450 (tests/learning/test_rnn_learning.py stops
it at 300; a feedforward policy stays under 60 there), and plays as well stepping its window one step at a time."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow
CONFIG = os.path.join(CONFIGS, "ppo_cartpole_masked_velocity_history.yaml")


def test_history_policy_reaches_400_on_masked_velocity_cartpole(tmp_path):
    # one torch thread: the run (and the policy it stops with) does not depend on the machine's load. The config's
    # score_to_win is 450; stopped at 400 (seed 5: 201k frames against 283k), the policy it stops with has played
    # 500 on every seed measured (docs/layout.md); at 300 it did not (126 on seed 2)
    over = [f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
            "params.torch_threads=1", "params.update_threads=1"]
    result = Runner().load(CONFIG, [*over, "params.config.score_to_win=400"]).train()
    assert result.mean_reward >= 400, result
    last = os.path.join(result.run_dir, "nn", "last_cartpole_masked_velocity_history.pth")
    one_thread = ["params.torch_threads=1", "params.update_threads=1"]
    played = Runner().load(CONFIG, one_thread).play(last, games=10, quiet=True)
    assert played.mean_reward >= 400, played
