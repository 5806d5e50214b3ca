"""Learning tier (slow): APG learns through the differentiable tensor envs (rlchain/configs/apg_*.yaml;
~15-35 s each on one CPU thread)."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow


def train(tmp_path, config, *extra):
    overrides = [f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
                 "params.torch_threads=1", *extra]
    return Runner().load(os.path.join(CONFIGS, config), overrides).train()


def test_apg_point_mass_reaches_success_0_9(tmp_path):
    result = train(tmp_path, "apg_point_mass.yaml")
    assert result.stop_reason.startswith("success_to_win"), result


def test_apg_pendulum_improves_past_minus_400(tmp_path):
    # a random policy scores about -1200; the run stops at the bar (the config's own score_to_win is -250)
    result = train(tmp_path, "apg_pendulum.yaml", "params.config.score_to_win=-400")
    assert result.best_reward >= -400, result
