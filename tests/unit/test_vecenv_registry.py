"""The vecenv_type registry: rl_games' vecenv.register(name, creator) and its lookup."""

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import env_configurations
from rlchain.config import ConfigError
from rlchain.envs import vecenv
from rlchain.envs.backends.rl_games_vecenv import IVecEnvAdapter
from rlchain.envs.factory import make_vec_env
from rlchain.envs.vecenv import resolve_vecenv_type
from rlchain.registry import VECENVS


class CountVecEnv:
    """An rl_games IVecEnv: obs = step counter per env, done every ``length`` steps (time-out on odd envs)."""

    def __init__(self, num_actors, length=3, tensor=False):
        self.n, self.length, self.tensor = num_actors, length, tensor
        self.t = np.zeros(num_actors, np.float32)

    def get_env_info(self):
        return {"observation_space": gym.spaces.Box(-np.inf, np.inf, (2,), np.float32),
                "action_space": gym.spaces.Discrete(2), "agents": 1, "value_size": 1}

    def get_number_of_agents(self):
        return 1

    def _obs(self):
        obs = np.stack([self.t, np.ones_like(self.t)], -1)
        return torch.as_tensor(obs) if self.tensor else obs

    def reset(self):
        self.t[:] = 0
        return self._obs()

    def step(self, actions):
        self.t += 1
        dones = self.t >= self.length
        time_outs = dones & (np.arange(self.n) % 2 == 1)
        self.t[dones] = 0
        rewards = np.ones(self.n, np.float32)
        if self.tensor:
            outs = {"time_outs": torch.as_tensor(time_outs)}
            return self._obs(), torch.as_tensor(rewards), torch.as_tensor(dones), outs
        return self._obs(), rewards, dones, {"time_outs": time_outs}


@pytest.fixture
def registered(scoped_registries):
    """A clean slot for test names in VECENVS and env_configurations."""
    yield


def test_register_and_lookup_with_rl_games_creator_signature(registered):
    calls = []

    def creator(config_name, num_actors, **kwargs):
        calls.append((config_name, num_actors, kwargs))
        return CountVecEnv(num_actors, **kwargs)

    vecenv.register("COUNT", creator)
    assert resolve_vecenv_type("COUNT") == ("COUNT", creator)
    env = make_vec_env("anything", {"length": 2}, 4, 0, "COUNT")
    assert calls == [("anything", 4, {"length": 2})]
    assert isinstance(env, IVecEnvAdapter) and env.num_envs == 4 and not env.env_spec.tensor_native
    obs = env.reset(0)
    assert obs.shape == (4, 2)
    env.step(np.zeros(4, np.int64))
    result = env.step(np.zeros(4, np.int64))
    assert result.terminated.tolist() == [True, False, True, False]
    assert result.truncated.tolist() == [False, True, False, True]
    assert result.reward.shape == (4,) and result.final_obs[:, 0].tolist() == [1, 1, 1, 1]
    with pytest.raises(ValueError, match="already registered"):
        vecenv.register("COUNT", lambda *a, **k: None)


def test_torch_ivecenv_is_a_tensor_env(registered):
    vecenv.register("count_torch", lambda name, n, **kw: CountVecEnv(n, tensor=True))
    env = make_vec_env("x", {}, 3, 0, "count_torch")
    assert env.env_spec.tensor_native and env.env_spec.device == torch.device("cpu")
    env.reset()
    result = env.step(torch.zeros(3, dtype=torch.long))
    assert isinstance(result.terminated, torch.Tensor) and result.terminated.dtype == torch.bool


def test_env_configurations_entry_selects_the_vecenv(registered):
    vecenv.register("RLGPU-test", lambda config_name, num_actors, **kw: CountVecEnv(num_actors, **kw))
    env_configurations.register("Count-test", {"vecenv_type": "RLGPU-test", "env_creator": lambda **kw: None},
                                overwrite=True)
    assert env_configurations.configurations["Count-test"]["vecenv_type"] == "RLGPU-test"
    env = make_vec_env("Count-test", {"length": 5}, 2, 0, None)
    assert isinstance(env, IVecEnvAdapter) and env.length == 5  # other attributes are the env's
    assert resolve_vecenv_type(None, "Count-test")[0] == "RLGPU-test"
    # the YAML's own vecenv_type wins over the entry's
    assert resolve_vecenv_type("sync", "Count-test")[0] == "sync"


def test_builtins_and_rl_games_aliases_are_registered():
    assert {"auto", "sync", "async", "native", "envpool", "ray"} <= set(VECENVS.names())
    assert resolve_vecenv_type("RAY")[0] == "ray" and resolve_vecenv_type("ENVPOOL")[0] == "envpool"
    assert resolve_vecenv_type(None)[0] == "auto"


def test_unknown_vecenv_type_is_one_line_with_did_you_mean():
    with pytest.raises(ConfigError) as err:
        resolve_vecenv_type("asyn")
    text = str(err.value)
    assert text.startswith("params.config.vecenv_type: unknown vecenv_type 'asyn'; did you mean 'async'")
    assert "(registered: async, auto," in text and "\n" not in text
