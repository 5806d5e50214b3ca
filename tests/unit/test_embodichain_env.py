"""EmbodiChain's env contract as a backend (rlchain/envs/backends/embodichain_env.py)."""

import torch

import rlchain.builtins  # noqa: F401
from rlchain.builtins import register_builtins
from rlchain.envs.backends.embodichain_env import flatten_obs, register_env
from rlchain.registry import ENVS

register_builtins()


def test_nested_dict_flattened_in_sorted_key_order():
    obs = {"b": torch.tensor([[3.0]]), "a": {"z": torch.tensor([[2.0]]), "y": torch.tensor([[1.0, 1.5]])}}
    assert flatten_obs(obs).tolist() == [[1.0, 1.5, 2.0, 3.0]]


def test_registered_contract_env_steps_as_a_tensor_vecenv():
    env = ENVS.get("EmbodiChainPushStandIn")(4, 0, device="cpu")
    obs = env.reset(seed=1)
    assert obs.shape == (4, 12) and env.observation_space.shape == (12,) and env.is_tensor_env
    result = env.step(torch.zeros(4, 2))
    assert result.obs.shape == (4, 12) and result.reward.shape == (4,)
    assert set(result.infos) >= {"success", "fail", "elapsed_steps", "metrics", "rewards"}
    assert set(result.infos["rewards"]) == {"reaching_reward", "goal_distance_reward", "action_penalty",
                                            "success_bonus"}


def test_register_env_decorator_and_unknown_cfg_key():
    @register_env("TinyContractEnv", overwrite=True)
    class Tiny:
        def __init__(self, num_envs, device, scale=1.0):
            self.num_envs, self.device, self.scale = num_envs, device, scale
            import gymnasium as gym
            import numpy as np
            self.single_action_space = gym.spaces.Box(-1, 1, (1,), np.float32)
            self.single_observation_space = gym.spaces.Box(-1, 1, (2,), np.float32)

        def reset(self, seed=None, options=None):
            return torch.zeros(self.num_envs, 2), {}

        def step(self, a):
            n = self.num_envs
            return (torch.ones(n, 2), a[:, 0] * self.scale, torch.zeros(n, dtype=torch.bool),
                    torch.ones(n, dtype=torch.bool), {})

    try:
        env = ENVS.get("TinyContractEnv")(3, None, scale=2.0)
        env.reset()
        assert env.step(torch.ones(3, 1)).reward.tolist() == [2.0, 2.0, 2.0]
        try:
            ENVS.get("TinyContractEnv")(3, None, scael=2.0)
        except ValueError as exc:
            assert "scael" in str(exc)
        else:
            raise AssertionError("unknown cfg key accepted")
    finally:
        ENVS.unregister("TinyContractEnv")
