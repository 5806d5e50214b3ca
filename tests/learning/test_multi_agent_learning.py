"""Learning tier (slow): two agents sharing one policy learn to meet (multi-agent batch flattening)."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow


@pytest.mark.timeout(240)  # two learning tests share the 2 cores (pytest -n 2)
def test_cooperative_agents_learn_to_meet(tmp_path):
    runner = Runner().load(os.path.join(CONFIGS, "ppo_test_cooperative.yaml"),
                           [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false",
                            # bound: 60 epochs (30.7k frames), 1.5 times the slowest of seeds 5, 1, 2 (20.0k, 8.2k)
                            "params.config.max_epochs=60"])
    result = runner.train()
    # mean per-agent episode reward; walking to one's own nearest flag gets about 0.49, random play 0.10
    assert result.mean_reward >= 0.95, result
    played = runner.play(os.path.join(result.run_dir, "nn", "cooperative.pth"), games=200, quiet=True)
    assert played.mean_reward >= 0.9, played
