"""Learning tier (slow): the push-cube example (rlchain/configs/embodichain/push_cube_ppo.json, MuJoCo)
learns to push: within 64 iterations on one thread it passes EmbodiChain's test (cube within 0.1 m of the goal)
in a share of evaluation episodes that zero and random actions never reach (every cube starts 0.15 m or more
from its goal); the run stops at the first evaluation that does (seed 2: the second, at iteration 32)."""

import os

import pytest

from rlchain import Runner
from rlchain.compare.runs import read_curves
from rlchain.training.events import Callback
from tests.conftest import CONFIGS

pytest.importorskip("mujoco")
pytestmark = pytest.mark.slow
BAR = 0.15  # the share of evaluation episodes that end with the cube within 0.1 m of its goal


class StopAtTheBar(Callback):
    """Stops the run after the first evaluation that reaches the bar, as a score_to_win stops a run."""

    def on_evaluation(self, ctx, result):
        if result.success_rate is not None and result.success_rate >= BAR:
            ctx.request_stop(f"evaluation success rate {result.success_rate:.3f}")


def test_push_cube_learns_to_push(tmp_path):
    overrides = ["trainer.iterations=64", "trainer.eval_freq=32768", "trainer.num_eval_episodes=32", "trainer.seed=2",
                 f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
                 "params.torch_threads=1"]
    result = Runner().load(os.path.join(CONFIGS, "embodichain", "push_cube_ppo.json"), overrides).train(
        callbacks=[StopAtTheBar()])
    success = read_curves(result.run_dir, ["eval/success_rate"])["eval/success_rate"].values
    # an evaluation every 16 iterations, the last at 64; zero and random actions: 0.000 of 1,024 episodes
    assert 1 <= len(success) <= 4 and max(success) >= BAR, success
