"""Dict observations flattened by a backend (gymnasium's layout, a Discrete one-hot) and handed back per key by
PerKeyObs (rlchain/envs/wrappers/dict_obs.py) for a multi_input network: the round trip, and envpool's Dict
tasks (MiniGrid: an image, a mission and a Discrete direction; DeepMind Control: position and velocity)."""

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.envs.wrappers.dict_obs import from_one_hot
from rlchain.envs.wrappers.spaces import flatten_dict_obs
from rlchain.models.build import build_env, build_model
from tests.conftest import CONFIGS

SPACE = gym.spaces.Dict({"pos": gym.spaces.Box(-1, 1, (2,), np.float32), "room": gym.spaces.Discrete(4, start=1),
                         "grid": gym.spaces.MultiDiscrete([[2, 3], [4, 2]], start=[[1, 0], [0, 5]])})


def test_batched_flattening_is_gymnasium_s_and_the_one_hots_come_back_as_values():
    SPACE.seed(0)
    rows = [SPACE.sample() for _ in range(6)]
    batch = {k: np.stack([r[k] for r in rows]) for k in SPACE.spaces}
    flat = flatten_dict_obs(batch, SPACE)
    assert np.array_equal(flat, np.stack([gym.spaces.flatten(SPACE, r) for r in rows]))
    assert list(SPACE.spaces) == ["grid", "pos", "room"]  # gymnasium sorts the keys: grid's 11 one-hot values first
    grid = from_one_hot(torch.as_tensor(flat[:, :11]), SPACE["grid"])
    room = from_one_hot(torch.as_tensor(flat[:, 13:]), SPACE["room"])
    assert room.dtype == torch.int64 and room.tolist() == batch["room"].tolist()
    assert grid.shape == (6, 2, 2) and grid.tolist() == batch["grid"].tolist()


def _envpool(task, *extra):
    pytest.importorskip("envpool")
    over = [f"params.config.env_name={task}", "params.config.vecenv_type=envpool", "params.network.name=multi_input",
            "params.network.mlp.units=[8]", "params.config.num_actors=2", *extra]
    return Runner().load(f"{CONFIGS}/ppo_cartpole.yaml", over).params


def test_envpool_minigrid_reaches_multi_input_per_key_with_its_direction_an_integer():
    params = _envpool("MiniGrid-Empty-5x5-v0", "params.network.inputs.image={encoder: cnn, units: [8]}")
    env = build_env(params, 2, 0)
    try:
        assert list(env.observation_space.spaces) == ["direction", "image", "mission"]
        obs = env.reset()
        raw = env.env.pools[0].reset()[0]  # the same pool, reset again: envpool's own dict
        assert obs["direction"].dtype == np.int64 and obs["direction"].tolist() == raw["direction"].tolist()
        assert obs["image"].dtype == np.uint8 and np.array_equal(obs["image"], raw["image"])
        model = build_model(params, env, torch.device("cpu"))
        kinds = {k: type(e).__name__ for k, e in model.a2c_network.actor_cnn.encoders.items()}
        assert kinds == {"direction": "EmbeddingEncoder", "image": "ImageEncoder", "mission": "FlatEncoder"}
        result = env.step(np.zeros(2, np.int64))
        assert result.obs["direction"].dtype == np.int64 and result.final_obs["image"].dtype == np.uint8
    finally:
        env.close()


def test_envpool_deepmind_control_keys_reach_multi_input_per_key():
    params = _envpool("CheetahRun-v1", "params.config.env_config={}")
    env = build_env(params, 2, 0)
    try:
        obs = env.reset()
        assert {k: (v.dtype, v.shape) for k, v in obs.items()} == {"position": (np.float32, (2, 8)),
                                                                     "velocity": (np.float32, (2, 9))}
    finally:
        env.close()
