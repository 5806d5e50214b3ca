"""PPO, SAC and DQN in Stable-Baselines3's shape, on rlchain's loop (see :mod:`rlchain.sb3.model`).

Arguments you leave out take SB3's defaults (:mod:`rlchain.sb3.defaults`; ``defaults="rlchain"``: rlchain's
packaged examples ``ppo_cartpole``, ``ppo_pendulum``, ``sac_pendulum``, ``dqn_cartpole`` instead); SB3's names you
pass are mapped to rlchain's keys (:mod:`rlchain.sb3.keys`, the table in docs/sb3.md), and any rlchain config key is
taken as it is.
"""

from __future__ import annotations

import gymnasium as gym

from rlchain.config.errors import ConfigError
from rlchain.sb3.model import BaseModel
from rlchain.sb3.model_load import Spaces


class PPO(BaseModel):
    """PPO (rl_games' ``a2c_discrete`` / ``a2c_continuous``): ``PPO("MlpPolicy", "CartPole-v1").learn(50_000)``."""

    algo = "ppo"


class SAC(BaseModel):
    """Soft actor-critic for continuous actions: ``SAC("MlpPolicy", "Pendulum-v1").learn(20_000)``."""

    algo = "sac"

    def _read_spaces(self) -> Spaces:
        """The env's spaces; Box actions only, as SB3's SAC (rlchain's own SAC also trains Discrete ones)."""
        spaces = super()._read_spaces()
        if not isinstance(spaces.action_space, gym.spaces.Box):
            raise ConfigError("rlchain.SAC", "env", f"SB3's SAC supports Box actions only, the env has "
                                                    f"{spaces.action_space} (SAC on Discrete actions: an rlchain "
                                                    f"YAML with algo sac, e.g. sac_cartpole)")
        return spaces


class DQN(BaseModel):
    """Double DQN with a dueling head for discrete actions: ``DQN("MlpPolicy", "CartPole-v1").learn(100_000)``."""

    algo = "dqn"
