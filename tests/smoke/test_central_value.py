"""Asymmetric actor-critic: central_value_config trains a critic on the env's state; bad setups fail early."""

import os

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt
from tests.conftest import CONFIGS
from tests.smoke.obs_state_cartpole import ENV_ID, central_value_config

pytestmark = pytest.mark.smoke
CONFIG = os.path.join(CONFIGS, "ppo_cartpole.yaml")


CV = central_value_config()


def overrides(tmp_path, epochs, *extra):
    return [f"params.config.train_dir={tmp_path}", f"params.config.max_epochs={epochs}",
            "params.config.print_stats=false", f"params.config.env_name={ENV_ID}",
            "params.config.save_best_after=0", "params.config.normalize_value=True", *extra]


def test_central_value_trains_saves_resumes_and_plays(tmp_path):
    runner = Runner().load(CONFIG, overrides(tmp_path, 2, f"params.config.central_value_config={CV}"))
    result = runner.train()
    assert result.epoch == 2
    last = os.path.join(result.run_dir, "nn", "last_cartpole.pth")
    state = ckpt.load(last)
    assert "central_value" in state and "central_value_agent" in state
    # the actor reads 2 numbers (obs), the critic 4 (state)
    assert state["model"]["a2c_network.actor_mlp.0.weight"].shape[1] == 2
    assert state["central_value"]["a2c_network.actor_mlp.0.weight"].shape[1] == 4
    resumed = Runner().load(CONFIG, overrides(tmp_path, 3, f"params.config.central_value_config={CV}")).train(
        checkpoint=last)
    assert resumed.epoch == 3
    played = Runner().load(CONFIG, overrides(tmp_path, 1, f"params.config.central_value_config={CV}")).play(
        last, games=2, quiet=True)
    assert played.games == 2


class HiddenRewardEnv(gym.Env):
    """The actor sees nothing; the state holds the per-step reward r and the steps left.

    The return is r times the (discounted) steps left: a critic on the state can fit it exactly,
    a critic on the (empty) observation cannot.
    """

    observation_space = gym.spaces.Dict({"obs": gym.spaces.Box(0, 0, (1,), np.float32),
                                         "state": gym.spaces.Box(-1, 1, (2,), np.float32)})
    action_space = gym.spaces.Discrete(2)
    LENGTH = 8

    def _obs(self):
        return {"obs": np.zeros(1, np.float32),
                "state": np.array([self.r, self.left / self.LENGTH], np.float32)}

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.r, self.left = float(self.np_random.uniform(-1, 1)), self.LENGTH
        return self._obs(), {}

    def step(self, action):
        self.left -= 1
        return self._obs(), self.r, self.left == 0, False, {}


if "HiddenRewardTest-v0" not in gym.registry:
    gym.register("HiddenRewardTest-v0", entry_point=HiddenRewardEnv)


def _value_fit(tmp_path, *extra):
    """R^2 of the trained critic against the true values 0.1 * r * (1 - gamma^left) / (1 - gamma)."""
    seen = {}

    def record(ctx, stats, episodes):
        seen["ctx"] = ctx

    runner = Runner().load(CONFIG, overrides(tmp_path, 25, "params.config.env_name=HiddenRewardTest-v0", *extra))
    runner.train(callbacks=[record])
    ctx = seen["ctx"]
    r, left = torch.meshgrid(torch.linspace(-1, 1, 21), torch.arange(1, HiddenRewardEnv.LENGTH + 1).float(),
                             indexing="ij")
    obs = torch.stack([torch.zeros_like(r), r, left / HiddenRewardEnv.LENGTH], -1).reshape(-1, 3)
    gamma = ctx.params.config.gamma
    true = (0.1 * r * (1 - gamma ** left) / (1 - gamma)).reshape(-1)
    critic = ctx.algorithm.central_value if ctx.algorithm.central_value is not None else ctx.model
    predicted = critic.value(obs).reshape(-1)
    return float(1 - (predicted - true).square().mean() / true.var())


def test_central_value_learns_values_from_the_state(tmp_path):
    """The critic trains on the state and fits the true values; the actor's own critic cannot."""
    assert _value_fit(tmp_path, f"params.config.central_value_config={CV}") > 0.7
    assert _value_fit(tmp_path) < 0.2


def test_central_value_needs_a_state(tmp_path):
    runner = Runner().load(CONFIG, [f"params.config.train_dir={tmp_path}", "params.config.max_epochs=1",
                                    f"params.config.central_value_config={CV}"])
    with pytest.raises(ConfigError, match="central_value_config: the env has no central-value state"):
        runner.train()


@pytest.mark.parametrize("override,expect", [
    ("params.network.central_value=True", "params.network.central_value: True makes a value-only critic"),
    ("params.config.central_value_config={network: {space: {discrete: }}}",
     "central_value_config.network.space: the central value network is a critic"),
    ("params.config.central_value_config={network: {mlp: {units: [8]}}, learning_rat: 1}", "did you mean"),
])
def test_central_value_config_errors(override, expect):
    with pytest.raises(ConfigError) as err:
        Runner().load(CONFIG, [override])
    assert expect in str(err.value)


def test_central_value_minibatch_is_checked_when_training_not_when_playing(tmp_path):
    override = "params.config.central_value_config={network: {mlp: {units: [8]}}, minibatch_size: 300}"
    runner = Runner().load(CONFIG, [override, f"params.config.train_dir={tmp_path}"])  # a player may load it
    with pytest.raises(ConfigError) as err:
        runner.train()
    assert ("central_value_config.minibatch_size: batch num_actors*horizon_length = 512 is not divisible by "
            "minibatch_size 300") in str(err.value)
    assert not os.listdir(tmp_path)  # before a run folder is made


def test_actor_without_central_value_ignores_the_state(tmp_path):
    """A {'obs','state'} env without central_value_config: the actor still reads only 'obs'."""
    result = Runner().load(CONFIG, overrides(tmp_path, 1)).train()
    state = ckpt.load(os.path.join(result.run_dir, "nn", "last_cartpole.pth"))
    assert state["model"]["a2c_network.actor_mlp.0.weight"].shape[1] == 2
    assert torch.isfinite(state["model"]["a2c_network.value.weight"]).all()


@pytest.mark.parametrize("actor_rnn", [False, True])
def test_recurrent_central_value(tmp_path, actor_rnn):
    """An LSTM critic (rl_games' test_asymmetric configs) with or without an RNN actor: train, resume."""
    cv = ("{network: {central_value: True, mlp: {units: [16]}, rnn: {name: lstm, units: 8}}, "
          "learning_rate: 1e-3, mini_epochs: 2, minibatch_size: 128}")
    extra = [f"params.config.central_value_config={cv}", "params.config.seq_length=4"]
    if actor_rnn:
        extra.append("params.network.rnn={name: gru, units: 8}")
    seen = {}

    def record(ctx, stats, episodes):
        seen["states"] = [tuple(s.shape) for s in ctx.algorithm.storage.states]
        seen["loss"] = stats["cval_loss"]

    result = Runner().load(CONFIG, overrides(tmp_path, 2, *extra)).train(callbacks=[record])
    # storage keeps the actor's states first (GRU: 1), then the critic's (LSTM: h, c)
    assert len(seen["states"]) == (3 if actor_rnn else 2) and np.isfinite(seen["loss"])
    last = os.path.join(result.run_dir, "nn", "last_cartpole.pth")
    resumed = Runner().load(CONFIG, overrides(tmp_path, 3, *extra)).train(checkpoint=last)
    assert resumed.epoch == 3


def test_multi_head_values(tmp_path):
    """An env with value_size 2 (vector rewards): two value heads, GAE per head, advantages summed."""
    seen = {}

    def record(ctx, stats, episodes):
        seen["values"] = tuple(ctx.algorithm.storage.values.shape)
        seen["rewards"] = ctx.algorithm.storage.rewards.clone()

    extra = ["params.config.env_name=test_env", "params.config.env_config={name: TestRnnEnv-v0, "
             "multi_head_value: True, apply_dist_reward: True}", "params.config.num_actors=4",
             "params.config.horizon_length=32", "params.config.minibatch_size=64"]
    result = Runner().load(CONFIG, overrides(tmp_path, 2, *extra)).train(callbacks=[record])
    assert result.epoch == 2
    assert seen["values"] == (32, 4, 2)
    assert bool((seen["rewards"][..., 1] != 0).any())  # the distance head gets its own rewards
    state = ckpt.load(os.path.join(result.run_dir, "nn", "last_cartpole.pth"))
    assert state["model"]["a2c_network.value.weight"].shape[0] == 2
