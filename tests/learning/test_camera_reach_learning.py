"""Learning tier (slow): on TorchCameraReach-v0, whose goal is only in the camera image, the multi_input
policy (a CNN on the image, an MLP on the proprioception) reaches a success rate of 0.6, and a policy that
sees only the proprioception stays at chance (its best, the table's centre, succeeds 2.8% of the time).
About 30 CPU seconds for the first (seed 5: 65.6k frames), less for the second."""

import os

import numpy as np
import pytest

from rlchain import Runner
from rlchain.compare.runs import read_curves
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow
CONFIG = os.path.join(CONFIGS, "ppo_camera_reach.yaml")
VECTOR_ONLY = ["params.config.env_config.observation=proprio",
               "params.network={name: actor_critic, space: {continuous: {fixed_sigma: True}}, "
               "mlp: {units: [128, 64], activation: elu}}"]


def _train(tmp_path, *extra):
    over = [f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false", *extra]
    result = Runner().load(CONFIG, over).train()
    return result, read_curves(result.run_dir, ["episodes/success_rate"])["episodes/success_rate"].values


def test_multi_input_policy_reaches_0_6_success(tmp_path):
    result, success = _train(tmp_path, "params.config.success_to_win=0.6", "params.config.max_epochs=200")
    assert max(success) >= 0.6, (result, success[-10:])


def test_vector_only_policy_stays_at_chance(tmp_path):
    # 60 epochs (96k frames): more than the multi-input policy takes to reach 0.6 (65.6k frames, seed 5)
    result, success = _train(tmp_path, "params.config.max_epochs=60", *VECTOR_ONLY)
    assert np.mean(success[-30:]) < 0.08, success[-30:]  # chance 0.028; 30 epochs of 64 episodes each
