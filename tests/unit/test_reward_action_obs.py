"""RewardActionObs (envs/wrappers/reward_action_obs.py): rl_games' {'observation', 'reward', 'last_action'}
observations, flattened: layout, clipping, episode starts, final_obs, pipelined groups, errors."""

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.config.errors import ConfigError
from rlchain.envs.vecenv import StepResult
from rlchain.envs.wrappers.dict_obs import FlatDictBox, split_flat_obs
from rlchain.envs.wrappers.reward_action_obs import RewardActionObs

N, ACTIONS, SHAPE = 3, 4, (2, 3, 3)


class FakeEnv:
    """uint8 frames filled with the step count; env i's episode ends every i + 2 steps; reward 5 * (-1)^t.

    ``env_groups``: two groups (rows 0..1, 2) stepped with send / recv.
    """

    def __init__(self, action_space=None, obs_dtype=np.uint8):
        self.num_envs = N
        self.observation_space = gym.spaces.Box(0, 255, SHAPE, obs_dtype)
        self.action_space = action_space or gym.spaces.Discrete(ACTIONS)
        self.t = np.zeros(N, np.int64)
        self.env_groups = [slice(0, 2), slice(2, 3)]
        self.sent = {}
        self.closed = False

    def _obs(self, t):
        return np.broadcast_to(np.asarray(t, np.uint8).reshape(-1, 1, 1, 1), (len(t), *SHAPE)).copy()

    def reset(self, seed=None):
        self.t[:] = 0
        return self._obs(self.t)

    def _step(self, rows):
        self.t[rows] += 1
        t = self.t[rows]
        done = t % (np.arange(N)[rows] + 2) == 0
        final = self._obs(t)
        self.t[rows] = np.where(done, 0, t)
        reward = (5.0 * (-1.0) ** t).astype(np.float32)
        return StepResult(self._obs(self.t[rows]), reward, done, np.zeros_like(done), final, {"k": 1})

    def step(self, actions):
        return self._step(slice(None))

    def send(self, group, actions):
        self.sent[group] = actions

    def recv(self, group):
        return self._step(self.env_groups[group])

    def render(self):
        return "frame"

    def close(self):
        self.closed = True


def parts(env, flat):
    return split_flat_obs(torch.from_numpy(flat), env.dict_space)


def test_layout_space_and_reset():
    env = RewardActionObs(FakeEnv(), "k")
    space = env.observation_space
    assert isinstance(space, FlatDictBox) and space.dtype == np.float32
    assert space.shape == (ACTIONS + int(np.prod(SHAPE)) + 1,) and list(space.dict_space.spaces) == [
        "last_action", "observation", "reward"]
    obs = env.reset(seed=1)
    assert obs.shape == (N, space.shape[0]) and obs.dtype == np.float32
    p = parts(env, obs)
    assert (p["last_action"].numpy() == np.eye(ACTIONS)[[0, 0, 0]]).all()  # action 0 at the start, one-hot
    assert (p["reward"].numpy() == 0).all() and (p["observation"].numpy() == 0).all()
    assert space.contains(obs[0])
    # the same layout as gymnasium's own flattening of the Dict
    sample = env.dict_space.sample()
    assert env.dict_space == space.dict_space and gym.spaces.flatdim(env.dict_space) == space.shape[0]
    assert gym.spaces.flatten(env.dict_space, sample).shape == space.shape


def test_step_carries_clipped_reward_and_action_and_scales_images():
    env = RewardActionObs(FakeEnv(), "k")
    env.reset()
    result = env.step(np.array([3, 1, 2]))
    p = parts(env, result.obs)
    assert np.allclose(p["observation"].numpy(), 1 / 255.0)  # frame value 1, uint8 scaled to [0, 1]
    assert (p["reward"].numpy() == -1.0).all()  # -5 clipped
    assert (p["last_action"].numpy().argmax(1) == [3, 1, 2]).all() and (p["last_action"].numpy().sum(1) == 1).all()
    assert result.infos == {"k": 1}


def test_episode_start_is_reward_zero_action_zero_and_final_obs_keeps_the_last_step():
    env = RewardActionObs(FakeEnv(), "k")
    env.reset()
    env.step(np.array([1, 1, 1]))
    result = env.step(np.array([2, 3, 3]))  # env 0 ends (every 2 steps), envs 1 and 2 go on
    assert list(result.terminated) == [True, False, False]
    now, final = parts(env, result.obs), parts(env, result.final_obs)
    assert now["reward"][0] == 0 and now["last_action"][0].argmax() == 0 and now["observation"][0].max() == 0
    assert final["reward"][0] == 1.0 and final["last_action"][0].argmax() == 2
    assert np.allclose(final["observation"][0].numpy(), 2 / 255.0)  # the last frame before the reset
    assert now["reward"][1] == 1.0 and now["last_action"][1].argmax() == 3  # env 1 goes on


def test_pipelined_groups_and_pass_through():
    inner = FakeEnv()
    env = RewardActionObs(inner, "k")
    env.reset()
    assert env.env_groups == inner.env_groups and env.render() == "frame"
    env.send(0, np.array([1, 2]))
    env.send(1, np.array([3]))
    first, second = env.recv(0), env.recv(1)
    assert first.obs.shape == (2, env.observation_space.shape[0]) and second.obs.shape[0] == 1
    assert list(parts(env, first.obs)["last_action"].numpy().argmax(1)) == [1, 2]
    assert parts(env, second.obs)["last_action"].numpy().argmax(1)[0] == 3
    env.close()
    assert inner.closed


def test_float_observations_are_not_scaled():
    env = RewardActionObs(FakeEnv(obs_dtype=np.float32), "k")
    env.reset()
    assert np.allclose(parts(env, env.step(np.zeros(N, np.int64)).obs)["observation"].numpy(), 1.0)


@pytest.mark.parametrize("space,pattern", [
    (gym.spaces.Box(-1, 1, (2,), np.float32), r"k: needs Discrete actions"),
    (gym.spaces.MultiDiscrete([2, 2]), r"k: needs Discrete actions"),
])
def test_non_discrete_actions_are_a_config_error(space, pattern):
    with pytest.raises(ConfigError, match=pattern):
        RewardActionObs(FakeEnv(action_space=space), "k")
