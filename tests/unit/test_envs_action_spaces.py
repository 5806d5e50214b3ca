"""Vecenv layer for the action spaces beyond Discrete and Box: masks (has/get_action_mask), Tuple actions,
Dict observations."""

import gymnasium as gym
import numpy as np
import pytest
import torch

import rlchain  # noqa: F401  (registers the test envs)
from rlchain.config.errors import ConfigError
from rlchain.envs.backends.gymnasium_env import GymnasiumVecEnv
from rlchain.envs.backends.tensor_env import TensorVecEnv
from rlchain.envs.factory import make_vec_env
from rlchain.envs.wrappers.action_masks import stack_masks
from rlchain.envs.wrappers.dict_obs import should_flatten, split_flat_obs
from rlchain.envs.wrappers.spaces import cast_actions


def _valid_actions(masks: np.ndarray, nvec: list[int]) -> np.ndarray:
    """The first allowed action of every dimension, (N, K)."""
    return np.stack([seg.argmax(1) for seg in np.split(masks, np.cumsum(nvec)[:-1], axis=1)], 1)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("mode", ["sync", "async"])
def test_gymnasium_masks_follow_the_env_state(mode):
    env = make_vec_env("TestMaskedActions-v0", {"multi_discrete": True, "max_steps": 3}, 4, 0, mode)
    try:
        env.reset()
        assert env.has_action_mask()
        for _ in range(7):  # crosses episode ends: masks after auto-reset belong to the new episode
            masks = env.get_action_mask()
            assert masks.shape == (4, 7) and masks.dtype == bool
            result = env.step(_valid_actions(masks, [4, 3]))
            assert not result.terminated.any() and (result.reward > 0).all()
        masks = env.get_action_mask()
        invalid = np.stack([(~seg).argmax(1) for seg in np.split(masks, [4], axis=1)], 1)
        breaks = ~np.split(masks, [4], axis=1)[0].all(1) | ~np.split(masks, [4], axis=1)[1].all(1)
        result = env.step(invalid)
        assert (result.terminated == breaks).all()
    finally:
        env.close()


@pytest.mark.timeout(60)
@pytest.mark.parametrize("mode", ["auto", "sync", "async"])
def test_envs_without_masks_say_so(mode):
    env = make_vec_env("CartPole-v1", {}, 2, 0, mode)
    try:
        assert env.has_action_mask() is False
    finally:
        env.close()


def test_tuple_actions_are_split_for_gymnasium():
    space = gym.spaces.Tuple([gym.spaces.Discrete(3), gym.spaces.Discrete(5)])
    out = cast_actions(torch.tensor([[0, 4], [2, 1]]), space, 2)
    assert isinstance(out, tuple) and [a.tolist() for a in out] == [[0, 2], [4, 1]]
    env = GymnasiumVecEnv("TestMultiDiscrete-v0", 2, "sync", {"tuple_actions": True})
    try:
        env.reset(seed=0)
        assert env.action_space == space
        result = env.step(np.array([[2, 4], [0, 0]]))
        assert result.obs.shape == (2, 3)
    finally:
        env.close()


def test_dict_observations_are_flattened_in_key_order():
    env = GymnasiumVecEnv("TestMultiDiscrete-v0", 2, "sync", {"dict_obs": True})
    plain = GymnasiumVecEnv("TestMultiDiscrete-v0", 2, "sync", {})
    try:
        assert env.observation_space.shape == (3,) and env.observation_space.dtype == np.float32
        np.testing.assert_array_equal(env.reset(seed=3), plain.reset(seed=3))
        a = np.array([[2, 3], [1, 0]])
        np.testing.assert_array_equal(env.step(a).obs, plain.step(a).obs)
    finally:
        env.close()
        plain.close()


def test_split_flat_obs_round_trip():
    space = gym.spaces.Dict({"image": gym.spaces.Box(0, 1, (2, 2, 2)), "pos": gym.spaces.Box(-1, 1, (3,)),
                             "mode": gym.spaces.Discrete(4)})
    sample = space.sample()
    flat = torch.as_tensor(gym.spaces.flatten(space, sample), dtype=torch.float32).unsqueeze(0)
    parts = split_flat_obs(flat, space)
    assert list(parts) == list(space.spaces)
    assert torch.allclose(parts["image"][0], torch.as_tensor(sample["image"]))
    assert torch.allclose(parts["pos"][0], torch.as_tensor(sample["pos"]))
    assert parts["mode"][0].argmax().item() == sample["mode"]  # Discrete entries are one-hot
    with pytest.raises(ValueError, match="flattens to"):
        split_flat_obs(flat[:, :-1], space)
    central = gym.spaces.Dict({"obs": gym.spaces.Box(0, 1, (2,)), "state": gym.spaces.Box(0, 1, (3,))})
    assert should_flatten(space) and not should_flatten(central)


def test_stack_masks():
    assert stack_masks([np.array([1, 0]), np.array([0, 1])], 2).tolist() == [[True, False], [False, True]]
    assert stack_masks(np.ones((3, 2, 2)), 3).shape == (3, 4)


class _MultiDiscreteTensorEnv(TensorVecEnv):
    def __init__(self, num_envs: int) -> None:
        self.observation_space = gym.spaces.Box(-1, 1, (1,))
        self.action_space = gym.spaces.MultiDiscrete([2, 3])
        super().__init__(num_envs)
        self.seen = None

    def _reset_idx(self, env_ids):
        return torch.zeros(len(env_ids), 1)

    def _step_physics(self, actions):
        self.seen = actions
        n = self.num_envs
        return torch.zeros(n, 1), torch.zeros(n), torch.zeros(n, dtype=torch.bool)


def test_tensor_env_multi_discrete_actions_and_mask_default():
    env = _MultiDiscreteTensorEnv(3)
    env.reset()
    env.step(torch.tensor([[1, 2], [0, 0], [1, 1]], dtype=torch.int32))
    assert env.seen.dtype == torch.int64 and env.seen.shape == (3, 2)
    with pytest.raises(ValueError, match="expected"):
        env.step(torch.zeros(3, 3, dtype=torch.long))
    assert env.has_action_mask() is False
    with pytest.raises(NotImplementedError):
        env.get_action_mask()


def test_use_action_masks_without_env_masks_is_a_one_line_config_error(tmp_path, base_config):
    from rlchain import Runner

    base_config["params"]["config"].update(use_action_masks=True, train_dir=str(tmp_path))
    with pytest.raises(ConfigError, match="params.config.use_action_masks") as info:
        Runner().load(base_config).train()
    assert "\n" not in str(info.value)


def test_use_action_masks_with_box_actions_is_a_config_error(tmp_path, base_config):
    from rlchain import Runner

    cfg = base_config["params"]
    cfg["algo"]["name"], cfg["model"]["name"] = "a2c_continuous", "continuous_a2c_logstd"
    cfg["network"]["space"] = {"continuous": None}
    cfg["config"].update(env_name="Pendulum-v1", use_action_masks=True, train_dir=str(tmp_path))
    with pytest.raises(ConfigError, match="params.config.use_action_masks: needs discrete"):
        Runner().load(base_config).train()
