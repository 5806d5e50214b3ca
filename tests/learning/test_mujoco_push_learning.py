"""Learning tier (slow): the push-cube example (rlchain/configs/embodichain/push_cube_ppo.json, MuJoCo)
learns to push: a short run of it on one thread passes EmbodiChain's test (cube within 0.1 m of the goal) in
a share of evaluation episodes that zero actions never reach (the config starts every cube 0.15 m or more
from its goal)."""

import os

import pytest

from rlchain import Runner
from rlchain.compare.runs import read_curves
from tests.conftest import CONFIGS

pytest.importorskip("mujoco")
pytestmark = pytest.mark.slow


def test_push_cube_learns_to_push(tmp_path):
    overrides = ["trainer.iterations=64", "trainer.eval_freq=16384", "trainer.seed=0",
                 f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
                 "params.torch_threads=1"]
    result = Runner().load(os.path.join(CONFIGS, "embodichain", "push_cube_ppo.json"), overrides).train()
    success = read_curves(result.run_dir, ["eval/success_rate"])["eval/success_rate"].values
    assert len(success) == 8 and max(success) >= 0.3, success
