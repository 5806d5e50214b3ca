"""compile_update through real PPO epochs: the compiled minibatch step learns what the eager one does."""

import os

import pytest
import torch

from rlchain import Runner
from rlchain.algos.ppo.trainer import OnPolicyTrainer
from rlchain.models.build import build_env, build_model
from rlchain.runs.logging import TrainLogger
from rlchain.training.loop import Loop
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke

KEYS = ("a_loss", "c_loss", "entropy", "kl", "clip_frac", "grad_norm")


def _epochs(compiled: bool, epochs: int = 2) -> list[dict[str, float]]:
    """Same-seed PPO epochs on TorchCartPole at 256 envs; the stats of each update."""
    overrides = ["params.config.num_actors=256", "params.config.minibatch_size=1024", "params.config.print_stats=false",
                 f"params.config.compile_update={compiled}"]
    params = Runner().load(os.path.join(CONFIGS, "ppo_torch_cartpole.yaml"), overrides).params
    torch.manual_seed(0)
    env = build_env(params, 256, 0)
    model = build_model(params, env, torch.device("cpu"))
    loop = Loop(params, OnPolicyTrainer, env, model, torch.device("cpu"), None, TrainLogger(None, False), 0, {})
    ppo = loop.algorithm
    assert (ppo.agent._losses_fn != ppo.agent._losses) == compiled  # the compiled region is in use, or not
    ppo.obs = torch.as_tensor(env.reset(seed=0))
    out = []
    for _ in range(epochs):
        ppo.rollout()
        out.append(ppo.learn())
    env.close()
    return out


def test_compiled_update_matches_eager_per_epoch():
    eager, compiled = _epochs(False), _epochs(True)
    for a, b in zip(eager, compiled):
        for key in KEYS:
            assert b[key] == pytest.approx(a[key], rel=1e-4, abs=1e-6), key
