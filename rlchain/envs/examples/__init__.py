"""Small example environments (rl_games' test envs and more) so every feature can be tried in seconds.

The tables below name them; :mod:`rlchain.builtins` registers them (gymnasium ids with gymnasium, the
rest in :data:`rlchain.registry.ENVS`). ``pz_dying`` is a PettingZoo-style module used by path
(``env_config: {env: rlchain.envs.examples.pz_dying}``) and registers nothing.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rlchain.envs.examples.asymmetric import TestAsymmetricCritic
from rlchain.envs.examples.cooperative import CooperativeEnv
from rlchain.envs.examples.duel import make_duel
from rlchain.envs.examples.goal_reach import GoalReachEnv
from rlchain.envs.examples.masked import MaskedActionsEnv
from rlchain.envs.examples.masked_velocity import make_cartpole_masked_velocity
from rlchain.envs.examples.multidiscrete import MultiDiscreteGoalEnv
from rlchain.envs.examples.rnn_env import TestRNNEnv, test_env

GYM_ENVS: dict[str, tuple[Callable[..., Any], dict[str, Any]]] = {
    "TestAsymmetricEnv-v0": (TestAsymmetricCritic, {}),
    "TestCooperativeEnv-v0": (CooperativeEnv, {"max_episode_steps": 20}),
    "TestGoalReach-v0": (GoalReachEnv, {}),
    "TestMaskedActions-v0": (MaskedActionsEnv, {}),
    "CartPoleMaskedVelocity-v1": (make_cartpole_masked_velocity, {}),
    "TestMultiDiscrete-v0": (MultiDiscreteGoalEnv, {}),
    "TestRnnEnv-v0": (TestRNNEnv, {}),
}
"""gymnasium id -> (entry point, ``gym.register`` keywords)."""

ENV_BUILDERS: dict[str, Callable[..., Any]] = {"duel": make_duel, "test_env": test_env}
"""``env_name`` -> builder, for :data:`rlchain.registry.ENVS` (the EmbodiChain stand-ins, tensor envs, have their
own table: :data:`rlchain.envs.examples.embodichain_standins.ENV_BUILDERS`, so that importing an example gymnasium
env does not import torch)."""
