"""Shipped tensor-env configs train for a couple of epochs through rlchain.Runner and play back;
TorchCartPole reaches 475 (slow tier)."""

import os

import pytest
import torch

from rlchain import Runner
from rlchain.runs import checkpoint as ckpt
from rlchain.training.events import Callback
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke

TENSOR_CONFIGS = [
    ("ppo_torch_cartpole.yaml", "TorchCartPole-v0", 4096),
    ("ppo_torch_pendulum.yaml", "TorchPendulum-v0", 1024),
    ("ppo_torch_reacher8.yaml", "TorchReacher8-v0", 1024),
]


def small(tmp_path, epochs=2):
    return [f"params.config.max_epochs={epochs}", f"params.config.train_dir={tmp_path}/runs",
            "params.config.save_best_after=0", "params.config.score_to_win=100000",
            "params.config.print_stats=false"]


@pytest.mark.parametrize("config,env_name,num_envs", TENSOR_CONFIGS)
def test_tensor_config_trains_saves_and_plays(tmp_path, config, env_name, num_envs):
    runner = Runner().load(os.path.join(CONFIGS, config), small(tmp_path))
    cfg = runner.params.config
    assert cfg.env_name == env_name and cfg.num_actors == num_envs
    assert cfg.env_config["device"] == cfg.device  # the env lives on the training device
    seen = []

    class Devices(Callback):
        def on_epoch_end(self, ctx, stats, episodes):
            seen.append((ctx.env_spec.tensor_native, ctx.training_env.device, ctx.algorithm.storage.obs.device))

    result = runner.train(callbacks=[Devices()])
    assert result.epoch == 2 and result.frames == 2 * cfg.horizon_length * num_envs
    assert seen and all(is_tensor and env_dev == obs_dev for is_tensor, env_dev, obs_dev in seen)
    last = os.path.join(result.run_dir, "nn", f"last_{cfg.name}.pth")
    state = ckpt.load(last)
    assert state["epoch"] == 2
    assert all(torch.isfinite(v).all() for v in state["model"].values() if v.is_floating_point())

    played = Runner().load(os.path.join(CONFIGS, config)).play(last, games=2, quiet=True)
    assert played.games == 2 and played.mean_length > 0


def test_tensor_env_resume_continues(tmp_path):
    config = os.path.join(CONFIGS, "ppo_torch_pendulum.yaml")
    first = Runner().load(config, small(tmp_path, epochs=1)).train()
    last = os.path.join(first.run_dir, "nn", "last_torch_pendulum.pth")
    resumed = Runner().load(config, small(tmp_path, epochs=2)).train(checkpoint=last)
    assert resumed.epoch == 2 and resumed.frames == 2 * 32 * 1024


@pytest.mark.slow
def test_torch_cartpole_reaches_475_and_plays_gymnasium_cartpole(tmp_path):
    """The shipped config's own score_to_win (4096 envs, about 35-50 epochs, a few seconds); the
    policy then balances gymnasium's CartPole-v1 too: the dynamics are the same."""
    config = os.path.join(CONFIGS, "ppo_torch_cartpole.yaml")
    result = Runner().load(config, [f"params.config.train_dir={tmp_path}/runs",
                                    "params.config.print_stats=false"]).train()
    assert result.mean_reward >= 475, result
    best = os.path.join(result.run_dir, "nn", "torch_cartpole.pth")
    on_gym = Runner().load(config, ["params.config.env_name=CartPole-v1", "params.config.env_config={}"]).play(
        best, games=5, quiet=True)
    assert on_gym.mean_reward >= 475, on_gym
