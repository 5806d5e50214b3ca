"""The one play() loop (rlchain/policy/play.py) that evaluation, the Player, video and export share:
games and steps limits, games shared evenly over the envs, action masks, RNN state, the one-env recording adapter."""

import os

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.envs.vecenv import StepResult
from rlchain.envs.wrappers.one_env import OneEnv
from rlchain.inference.player import Player
from rlchain.models.build import build_env, build_model
from rlchain.policy.play import game_quota, play
from rlchain.training.evaluation import run_episodes
from tests.conftest import CONFIGS

CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
MASKED = os.path.join(CONFIGS, "ppo_test_masked.yaml")


def _model_and_env(config, overrides=(), num_envs=2):
    params = Runner().load(config, list(overrides)).params
    env = build_env(params, num_envs, 0)
    torch.manual_seed(0)
    return params, build_model(params, env, torch.device("cpu")), env


def test_games_and_steps_limits_and_what_the_policy_meets():
    _, model, env = _model_and_env(CARTPOLE, ["params.config.env_config={max_episode_steps: 8}"])
    try:
        model.train()
        seen = []
        result = play(model, env, None, steps=5, on_obs=lambda obs, masks: seen.append((obs.shape, masks)))
        assert seen == [((2, 4), None)] * 6 and result.games == 0  # 5 steps, 6 observation batches
        assert model.training  # its mode is restored
        games = play(model, env, 3, seed=1)
        assert games.games == 3 and len(games.rewards) == 3 and games.mean_length <= 8
        assert run_episodes(model, env, 3, True, torch.device("cpu"), seed=1).rewards == games.rewards
        with pytest.raises(ValueError, match="games or steps"):
            play(model, env, None)
    finally:
        env.close()


def test_masked_policies_act_under_the_env_masks():
    _, model, env = _model_and_env(MASKED, ["params.config.use_action_masks=True", "params.model.name=discrete_a2c",
                                            "params.network.space={discrete: null}",
                                            "params.config.env_config.multi_discrete=False"])
    masks_seen = []
    try:
        play(model, env, None, steps=4, on_obs=lambda obs, masks: masks_seen.append(masks))
    finally:
        env.close()
    assert len(masks_seen) == 5 and all(m.shape == (2, 6) and m.dtype == torch.bool for m in masks_seen)
    _, unmasked_env_model, cartpole = _model_and_env(CARTPOLE)
    unmasked_env_model.use_action_masks = True  # a masked policy on an env without masks: one-line error
    try:
        with pytest.raises(ConfigError, match="params.config.use_action_masks"):
            play(unmasked_env_model, cartpole, 1)
    finally:
        cartpole.close()


def test_rnn_state_is_zeroed_where_an_episode_ends():
    _, model, env = _model_and_env(CARTPOLE, ["params.network.rnn={name: gru, units: 8}",
                                              "params.config.env_config={max_episode_steps: 3}"], num_envs=1)
    zeroed = []
    original = model.act

    def act(obs, **kwargs):
        zeroed.append(bool((kwargs["states"][0] == 0).all()))
        return original(obs, **kwargs)

    model.act = act
    try:
        play(model, env, 2)
    finally:
        env.close()
    assert zeroed == [True, False, False, True, False, False]  # 2 games of 3 steps


class UnevenEpisodes:
    """Two envs: env 0's episodes last 1 step and score 1, env 1's last 10 steps and score 10."""

    num_envs = 2
    observation_space = gym.spaces.Box(-1, 1, (4,), np.float32)
    action_space = gym.spaces.Discrete(2)

    def __init__(self):
        self.t = 0

    def reset(self, seed=None):
        return np.zeros((2, 4), np.float32)

    def step(self, actions):
        self.t += 1
        done = np.array([True, self.t % 10 == 0])
        return StepResult(np.zeros((2, 4), np.float32), np.ones(2, np.float32), done, np.zeros(2, bool),
                          None, {})


def test_games_are_shared_evenly_so_short_episodes_are_not_over_counted():
    assert game_quota(5, 3) == [2, 2, 1] and game_quota(2, 4) == [1, 1, 0, 0] and game_quota(None, 2) is None
    _, model, _ = _model_and_env(CARTPOLE)
    result = play(model, UnevenEpisodes(), 4)
    assert sorted(result.rewards) == [1.0, 1.0, 10.0, 10.0]  # the first four to end: [1.0] * 4
    assert result.mean_length == 5.5


class CountingEnv(gym.Env):
    """Episodes of 2 steps; records the seed of every reset."""

    observation_space = gym.spaces.Box(-1, 1, (4,), np.float32)
    action_space = gym.spaces.Discrete(2)

    def __init__(self):
        self.seeds, self.t = [], 0

    def reset(self, *, seed=None, options=None):
        self.seeds.append(seed)
        self.t = 0
        return np.zeros(4, np.float32), {}

    def step(self, action):
        self.t += 1
        return np.zeros(4, np.float32), 1.0, self.t >= 2, False, {}


def test_the_recording_adapter_resets_per_game_and_not_after_the_last():
    _, model, cartpole = _model_and_env(CARTPOLE, num_envs=1)
    cartpole.close()
    inner = CountingEnv()
    result = play(model, OneEnv(inner, 3), 3, seed=10)
    assert result.rewards == [2.0, 2.0, 2.0] and inner.seeds == [10, 11, 12]  # no 4th video started


def test_player_opens_no_env_for_a_bad_checkpoint_and_closes_one_it_cannot_use(tmp_path, monkeypatch):
    import rlchain.policy.load as load_module

    opened, closed = [], []

    def build(*args, **kwargs):
        env = build_env(*args, **kwargs)
        opened.append(env)
        close = env.close
        env.close = lambda: (closed.append(True), close())
        return env

    monkeypatch.setattr(load_module, "build_env", build)
    params = Runner().load(CARTPOLE).params
    bad = tmp_path / "bad.pth"
    bad.write_bytes(b"not a checkpoint")
    with pytest.raises(Exception):  # noqa: B017 (whatever the loader raises)
        Player(params, str(bad))
    assert opened == [] and closed == []  # the checkpoint is read before any env opens
    with pytest.raises(ConfigError, match="--sigma"):  # CartPole's policy has no sigma to set
        Player(params, None, sigma=0.5)
    assert len(opened) == 1 and closed == [True]
