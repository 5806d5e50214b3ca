"""rlchain's tensor envs (TorchCartPole-v0, TorchPendulum-v0, TorchReacher8-v0) registered through rl_games'
own vecenv API, so rl_games (1.6.5 or its main branch, 2.0) trains on the very env rlchain's tensor-env rows
measure: ``benchmarks/peers/rl_games_driver.py --tensor-env`` calls :func:`register` before building its Runner.

The adapter is what an Isaac Lab user writes for rl_games (an ``IVecEnv`` whose ``step`` returns torch tensors
on the training device, episode ends reset in the same step, ``time_outs`` in the infos for
``value_bootstrap``); the env itself is rlchain's, imported from this checkout. Runs in the peer's venv:
it needs torch, gymnasium and rl_games there, nothing else of rlchain's requirements.
"""

from __future__ import annotations

import os
import sys
from typing import Any

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
VECENV_TYPE = "RLCHAIN_TENSOR"


def make_env(env_name: str, num_actors: int, **env_config: Any) -> Any:
    """The rlchain tensor env ``env_name`` with ``num_actors`` rows (``env_config``: device, seed, the env's
    own keys), built by the vecenv_creator of its entry in rlchain's env table (registry.ENVS)."""
    if REPO not in sys.path:
        sys.path.insert(0, REPO)
    import rlchain.envs.backends.torch_envs  # noqa: F401  (registers the tensor envs)
    from rlchain.registry import ENVS

    seed = env_config.pop("seed", None)
    return ENVS[env_name]["vecenv_creator"](num_actors, seed, **env_config)


def register(env_name: str) -> None:
    """Register ``env_name`` in rl_games' env_configurations with a vecenv type that steps it as tensors."""
    from rl_games.common import env_configurations, vecenv
    from rl_games.common.ivecenv import IVecEnv

    class TensorEnv(IVecEnv):
        """rl_games' view of one rlchain tensor env: tensors in, tensors out, on the env's device."""

        def __init__(self, config_name: str, num_actors: int, **kwargs: Any) -> None:
            self.env = make_env(env_name, num_actors, **kwargs)

        def step(self, actions: Any) -> tuple[Any, Any, Any, dict]:
            result = self.env.step(actions)
            dones = result.terminated | result.truncated
            return result.obs, result.reward, dones, {"time_outs": result.truncated}

        def reset(self) -> Any:
            return self.env.reset()

        def get_number_of_agents(self) -> int:
            return 1

        def get_env_info(self) -> dict:
            return {"action_space": self.env.action_space, "observation_space": self.env.observation_space}

    vecenv.register(VECENV_TYPE, TensorEnv)  # rl_games calls it as (config_name, num_actors, **env_config)
    env_configurations.register(env_name, {"vecenv_type": VECENV_TYPE, "env_creator": lambda **kwargs: None})
