"""Learning tier (slow): on the memory env an LSTM policy finds the goal, a feedforward one cannot."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow


def train(tmp_path, *extra):
    config = os.path.join(CONFIGS, "ppo_test_rnn_env.yaml")
    overrides = [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false", *extra]
    return Runner().load(config, overrides).train()


@pytest.mark.timeout(300)  # two learning tests share the 2 cores (pytest -n 2)
def test_rnn_remembers_the_goal(tmp_path):
    assert train(tmp_path).mean_reward >= 0.95  # success rate over the last 200 episodes


@pytest.mark.timeout(180)  # two learning tests share the 2 cores (pytest -n 2)
def test_feedforward_cannot(tmp_path):
    result = train(tmp_path, "params.network.rnn=None", "params.config.max_epochs=100")
    assert result.mean_reward < 0.4, result  # measured ~0.15: its path cannot depend on the goal
