"""A user-registered vector env (rl_games' vecenv.register) selected by ``vecenv_type`` in a YAML."""

import os

import gymnasium as gym
import numpy as np
import pytest
import yaml

from rlchain import Runner
from rlchain.config import ConfigError
from rlchain.envs import vecenv
from tests.conftest import CONFIGS
from tests.smoke.test_train_play_resume import small

pytestmark = pytest.mark.smoke


class ReachVecEnv:
    """A tiny numpy IVecEnv (rl_games' shape): move a point on a line to the target at 0 in 8 steps."""

    def __init__(self, num_actors, seed=0):
        self.n = num_actors
        self.rng = np.random.default_rng(seed)
        self.x = np.zeros(num_actors, np.float32)
        self.t = np.zeros(num_actors, np.int64)
        self.created_with = (num_actors, seed)

    def get_env_info(self):
        return {"observation_space": gym.spaces.Box(-np.inf, np.inf, (1,), np.float32),
                "action_space": gym.spaces.Discrete(3), "agents": 1, "value_size": 1}

    def get_number_of_agents(self):
        return 1

    def reset(self):
        self.x = self.rng.uniform(-2, 2, self.n).astype(np.float32)
        self.t[:] = 0
        return self.x[:, None].copy()

    def step(self, actions):
        self.x += 0.5 * (np.asarray(actions) - 1)
        self.t += 1
        rewards = -np.abs(self.x)
        dones = self.t >= 8
        self.x[dones] = self.rng.uniform(-2, 2, int(dones.sum()))
        self.t[dones] = 0
        return self.x[:, None].copy(), rewards, dones, {"time_outs": dones.copy()}


CREATED = []


def create_reach(config_name, num_actors, seed=None, **kwargs):
    CREATED.append((config_name, num_actors, seed, kwargs))
    return ReachVecEnv(num_actors, seed or 0)


@pytest.fixture
def my_vecenv(scoped_registries):
    vecenv.register("my_vecenv", create_reach)
    CREATED.clear()


def write_config(tmp_path, vecenv_type):
    with open(os.path.join(CONFIGS, "ppo_cartpole.yaml")) as fh:
        raw = yaml.safe_load(fh)
    raw["params"]["config"].update({"name": "reach", "env_name": "reach_line", "vecenv_type": vecenv_type,
                                    "num_actors": 8, "minibatch_size": 64})
    path = tmp_path / "reach.yaml"
    path.write_text(yaml.safe_dump(raw))
    return str(path)


def test_user_vecenv_trains_through_runner(tmp_path, my_vecenv):
    path = write_config(tmp_path, "my_vecenv")
    result = Runner().load(path, small(tmp_path)).train()
    assert result.epoch == 2 and result.frames == 2 * 8 * 16
    assert CREATED[0][:2] == ("reach_line", 8)
    assert os.path.isfile(os.path.join(result.run_dir, "nn", "last_reach.pth"))


def test_bad_vecenv_type_names_file_key_and_choices(tmp_path, my_vecenv):
    path = write_config(tmp_path, "my_vecnv")
    with pytest.raises(ConfigError) as err:
        Runner().load(path, small(tmp_path)).train()
    text = str(err.value)
    assert text.startswith(f"{path}: params.config.vecenv_type: unknown vecenv_type 'my_vecnv'; "
                           f"did you mean 'my_vecenv'?"), text
    assert "registered: async, auto," in text and "\n" not in text
