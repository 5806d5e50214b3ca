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
    env = ENVS["EmbodiChainPushStandIn"]["vecenv_creator"](4, 0, device="cpu")
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
        env = ENVS["TinyContractEnv"]["vecenv_creator"](3, None, scale=2.0)
        env.reset()
        assert env.step(torch.ones(3, 1)).reward.tolist() == [2.0, 2.0, 2.0]
        try:
            ENVS["TinyContractEnv"]["vecenv_creator"](3, None, scael=2.0)
        except ValueError as exc:
            assert "scael" in str(exc)
        else:
            raise AssertionError("unknown cfg key accepted")
    finally:
        ENVS.unregister("TinyContractEnv")


def test_nested_dict_observations_reach_a_multi_input_network_per_key():
    import gymnasium as gym
    import numpy as np

    from rlchain import Runner
    from rlchain.models.build import build_env, build_model
    from tests.conftest import CONFIGS

    @register_env("NestedDictContractEnv", overwrite=True)
    class Nested:
        """A nested dict observation: a (1, 4, 4) uint8 camera beside the robot's qpos (3) and a scalar phase."""

        def __init__(self, num_envs, device):
            self.num_envs, self.device = num_envs, device
            self.single_action_space = gym.spaces.Box(-1, 1, (2,), np.float32)
            self.single_observation_space = gym.spaces.Dict({})  # a dict: the keys come from the first observation

        def _obs(self):
            rows = torch.arange(self.num_envs, dtype=torch.float32)
            return {"robot": {"qpos": rows[:, None].repeat(1, 3), "phase": rows / 10},
                    "camera": torch.full((self.num_envs, 1, 4, 4), 200, dtype=torch.uint8)}

        def reset(self, seed=None, options=None):
            return self._obs(), {}

        def step(self, actions):
            zeros = torch.zeros(self.num_envs, dtype=torch.bool)
            return self._obs(), torch.zeros(self.num_envs), zeros, zeros, {}

    over = ["params.config.env_name=NestedDictContractEnv", "params.network.name=multi_input",
            "params.network.mlp.units=[8]", "params.network.inputs.camera={encoder: cnn, units: [8]}",
            "params.config.num_actors=2"]
    params = Runner().load(f"{CONFIGS}/ppo_pendulum.yaml", over).params
    flat = ENVS["NestedDictContractEnv"]["vecenv_creator"](2, 0, device="cpu")
    assert flat.reset().shape == (2, 16 + 1 + 3)  # a flat network's input is as before: sorted keys, floats
    env = build_env(params, 2, 0)
    assert tuple(env.observation_space.spaces) == ("camera", "robot/phase", "robot/qpos")
    obs = env.reset()
    assert obs["camera"].dtype == torch.uint8 and bool((obs["camera"] == 200).all())
    assert obs["robot/qpos"][1].tolist() == [1, 1, 1] and torch.equal(obs["robot/phase"], torch.tensor([0.0, 0.1]))
    model = build_model(params, env, torch.device("cpu"))
    assert model.a2c_network.actor_cnn.keys == ("camera", "robot/phase", "robot/qpos")
    assert model.act(obs)["actions"].shape == (2, 2)
