"""The env ``evaluate()`` plays: the training env, or the one ``evaluation_config`` names.

RLlib builds its evaluation env runners from the config merged with ``evaluation_config``, so
``.evaluation(evaluation_config=PPOConfig.overrides(env="CartPole-v1"))`` trains on one env and evaluates on
another (RLlib's ``cartpole_truncated_ppo.py`` trains on a 50-step CartPole and evaluates on the 500-step one).
An ``env`` or ``env_config`` in ``evaluation_config`` gives the run's params with that env in place of the
training env; the other evaluation overrides are read where they apply (``explore``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from rlchain.config.params import Params
from rlchain.rllib import envs


def evaluation_params(settings: dict[str, Any], params: Params) -> Params:
    """``params`` (the run's rlchain params) for the evaluation env: unchanged without an ``env`` or
    ``env_config`` override; otherwise a copy whose ``env_name`` builds the overriding env (registered once per
    call: the algorithm keeps the answer)."""
    overrides = settings.get("evaluation_config") or {}
    if not isinstance(overrides, dict) or ("env" not in overrides and "env_config" not in overrides):
        return params
    env = overrides.get("env", settings.get("env"))
    env_config = overrides.get("env_config", settings.get("env_config")) or {}
    make, label = envs.env_maker(env, dict(env_config), 0, 1)
    name = envs.register(make, f"{label} (evaluation_config)")
    return dataclasses.replace(params, config=dataclasses.replace(params.config, env_name=name, env_config={}))
