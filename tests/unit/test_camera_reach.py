"""TorchCameraReach-v0: the goal is only in the camera image, success is judged when the episode ends,
and wrong env_config values are one-line errors naming the key."""

import gymnasium as gym
import pytest
import torch

from rlchain.config.errors import ConfigError
from rlchain.envs.backends.torch_envs import TorchCameraReach
from rlchain.envs.factory import make_vec_env
from rlchain.envs.obs_dict import ObsDict


def test_dict_observation_image_uint8_and_proprio_without_the_goal():
    env = TorchCameraReach(8, seed=0)
    obs = env.reset()
    assert isinstance(env.observation_space, gym.spaces.Dict)
    assert isinstance(obs, ObsDict) and obs["image"].dtype == torch.uint8 and obs["image"].shape == (8, 1, 24, 24)
    assert obs["proprio"].shape == (8, 4)
    goal = env.state[:, 2:4]
    assert not any(torch.allclose(obs["proprio"][:, i], goal[:, j]) for i in range(4) for j in range(2))
    # the brightest pixel of each image lies at the goal (the robot is drawn at half brightness)
    flat = obs["image"].view(8, -1).float().argmax(1)
    row, col = flat // 24, flat % 24
    x = (col.float() + 0.5) / 24 * 2 - 1
    y = 1 - (row.float() + 0.5) / 24 * 2
    assert torch.allclose(torch.stack((x, y), 1), goal, atol=2.5 / 24 * 2)


def test_success_only_when_the_episode_ends_at_the_goal():
    env = TorchCameraReach(2, seed=1, max_episode_steps=3)
    env.reset()
    for step in range(3):
        goal = env.state[:, 2:4].clone()
        to_goal = (goal - env.state[:, 0:2]) / env.step_size
        result = env.step(to_goal.clamp(-1, 1))
        assert not bool(result.terminated.any())
        if step < 2:
            assert not bool(result.infos["success"].any())
    assert bool(result.truncated.all())
    final_distance = (result.final_obs["proprio"][:, 0:2] - goal).norm(dim=-1)  # the goal before the reset
    assert bool((final_distance < env.success_threshold).any())
    assert result.infos["success"].tolist() == (final_distance < env.success_threshold).tolist()


def test_proprio_observation_is_a_box_for_the_vector_only_baseline():
    env = TorchCameraReach(4, seed=0, observation="proprio")
    assert env.observation_space.shape == (4,)
    assert env.reset().shape == (4, 4)


def test_state_observation_is_the_proprio_then_the_goal_for_a_state_teacher():
    state = TorchCameraReach(4, seed=3, observation="state")
    seen = TorchCameraReach(4, seed=3, observation="dict", privileged=True)
    flat, keyed = state.reset(), seen.reset()
    assert state.observation_space.shape == (6,) and flat.shape == (4, 6)
    assert torch.equal(flat, torch.cat((keyed["proprio"], keyed["goal"]), 1))  # distill: teacher [proprio, goal]


@pytest.mark.parametrize("key, value", [("observation", "pixels"), ("image_size", 4), ("max_episode_steps", None),
                                        ("privileged", "yes")])
def test_wrong_env_config_values_name_the_key(key, value):
    with pytest.raises((ConfigError, ValueError), match=f"env_config.{key}"):
        make_vec_env("TorchCameraReach-v0", {key: value}, 2, 0, None)
