"""EnvSpec (rlchain/envs/spec.py): what the factory's envs carry, read once; and the env-building
module that the factory and the Ray worker share without importing each other."""

import ast
import dataclasses
import os
from types import SimpleNamespace

import gymnasium as gym
import pytest
import torch

from rlchain.envs.factory import make_vec_env
from rlchain.envs.spec import EnvSpec, describe, env_spec, mask_size_of
from rlchain.envs.vecenv import StepResult
from tests.conftest import ROOT


def test_factory_envs_carry_their_spec():
    env = make_vec_env("CartPole-v1", {}, 3, 0, "sync")
    try:
        spec = env.env_spec
        assert isinstance(spec, EnvSpec) and env_spec(env) is spec
        assert (spec.num_envs, spec.num_agents, spec.num_actors, spec.value_size) == (3, 1, 3, 1)
        assert spec.mask_size is None and not spec.action_masks and not spec.tensor_native
        assert spec.groups is None and not spec.central_value and not spec.self_play
        assert spec.action_space == gym.spaces.Discrete(2) and spec.observation_space.shape == (4,)
        with pytest.raises(dataclasses.FrozenInstanceError):
            spec.num_envs = 4
    finally:
        env.close()


@pytest.mark.parametrize("name,config,expected", [
    ("TestMaskedActions-v0", {}, {"mask_size": 6, "num_agents": 1}),
    ("TestMaskedActions-v0", {"multi_discrete": True}, {"mask_size": 7}),
    ("TestCooperativeEnv-v0", {}, {"num_agents": 2, "num_actors": 2, "num_envs": 4}),
    ("TorchCartPole-v0", {}, {"tensor_native": True, "device": torch.device("cpu")}),
    ("duel", {}, {"self_play": True, "scores": True}),
])
def test_spec_reads_the_optional_parts_of_the_contract(name, config, expected):
    env = make_vec_env(name, config, 2, 0, None)
    try:
        spec = env.env_spec
        assert {key: getattr(spec, key) for key in expected} == expected
    finally:
        env.close()


def test_spec_actions_go_to_the_env_as_it_takes_them():
    actions = torch.tensor([1, 0])
    numpy_spec = describe(SimpleNamespace(num_envs=2))
    assert numpy_spec.to_env(actions).tolist() == [1, 0] and not torch.is_tensor(numpy_spec.to_env(actions))
    tensor_spec = describe(SimpleNamespace(num_envs=2, is_tensor_env=True, device="cpu"))
    assert tensor_spec.to_env(actions) is actions


def test_hand_made_envs_are_described_once_and_wrappers_get_their_own_spec():
    calls = []

    class Env:
        num_envs, value_size = 4, 3

        def has_action_mask(self):
            calls.append(1)
            return False

    class Wrapper:  # passes every other attribute through, as RewardActionObs does
        num_envs = 4

        def __init__(self, env):
            self.env = env

        def __getattr__(self, name):
            return getattr(self.env, name)

    env = Env()
    assert env_spec(env) is env_spec(env) and len(calls) == 1
    assert env_spec(env).value_size == 3
    wrapped = Wrapper(env)
    assert env_spec(wrapped) is not env_spec(env)  # its own spec, not the inner env's attribute


def test_mask_sizes():
    assert mask_size_of(gym.spaces.Discrete(5)) == 5
    assert mask_size_of(gym.spaces.MultiDiscrete([4, 3])) == 7
    assert mask_size_of(gym.spaces.Tuple((gym.spaces.Discrete(2), gym.spaces.Discrete(3)))) == 5
    assert mask_size_of(gym.spaces.Box(-1, 1, (2,))) == 0


def test_pipelined_groups_are_in_the_spec():
    groups = [slice(0, 2), slice(2, 4)]
    spec = describe(SimpleNamespace(num_envs=4, env_groups=groups, step=lambda a: StepResult(*[None] * 5)))
    assert spec.groups == tuple(groups)
    assert describe(SimpleNamespace(num_envs=1, use_central_value=True)).central_value


def _imports(path, inside_functions):
    """Modules the file at ``path`` imports (``from X import ...``), only those inside functions
    when ``inside_functions``."""
    tree = ast.parse(open(path).read())
    scopes = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)] if inside_functions else [tree]
    return {node.module for scope in scopes for node in ast.walk(scope) if isinstance(node, ast.ImportFrom)}


def test_factory_and_ray_worker_share_the_building_module_without_a_cycle():
    envs = os.path.join(ROOT, "rlchain", "envs")
    assert "rlchain.envs.ray.ray_env" not in _imports(os.path.join(envs, "factory.py"), inside_functions=True)
    assert "rlchain.envs.factory" not in _imports(os.path.join(envs, "ray", "ray_worker.py"), inside_functions=False)
    assert "rlchain.envs.building" in _imports(os.path.join(envs, "ray", "ray_worker.py"), inside_functions=False)
    building = _imports(os.path.join(envs, "building.py"), inside_functions=False)
    assert not building & {"rlchain.envs.factory", "rlchain.envs.ray.ray_env", "rlchain.envs.ray.ray_worker"}
