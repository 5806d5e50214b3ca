"""Learning tier (slow): the push-cube example (rlchain/configs/embodichain/push_cube_ppo.json, MuJoCo)
learns to push: 64 iterations of it on one thread pass EmbodiChain's test (cube within 0.1 m of the goal) in
a share of evaluation episodes that zero and random actions never reach (every cube starts 0.15 m or more
from its goal). About 40 s of one core."""

import os

import pytest

from rlchain import Runner
from rlchain.compare.runs import read_curves
from tests.conftest import CONFIGS

pytest.importorskip("mujoco")
pytestmark = pytest.mark.slow


def test_push_cube_learns_to_push(tmp_path):
    overrides = ["trainer.iterations=64", "trainer.eval_freq=32768", "trainer.num_eval_episodes=32", "trainer.seed=2",
                 f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
                 "params.torch_threads=1"]
    result = Runner().load(os.path.join(CONFIGS, "embodichain", "push_cube_ppo.json"), overrides).train()
    success = read_curves(result.run_dir, ["eval/success_rate"])["eval/success_rate"].values
    assert len(success) == 4 and max(success) >= 0.15, success  # zero and random actions: 0.000 of 1,024
