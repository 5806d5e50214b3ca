"""The env ``evaluate()`` plays: the training env, or the one ``evaluation_config`` names.

RLlib builds its evaluation env runners from the config merged with ``evaluation_config``, so
``.evaluation(evaluation_config=PPOConfig.overrides(env="CartPole-v1"))`` trains on one env and evaluates on
another (RLlib's ``cartpole_truncated_ppo.py`` trains on a 50-step CartPole and evaluates on the 500-step one).
An ``env`` or ``env_config`` in ``evaluation_config`` gives the run's params with that env in place of the
training env; the other evaluation overrides are read where they apply (``explore``).
"""

from __future__ import annotations

import copy
import dataclasses
from typing import Any

from rlchain.config.params import Params
from rlchain.rllib import envs
from rlchain.rllib.results import deep_update


def evaluation_params(settings: dict[str, Any], params: Params) -> Params:
    """``params`` (the run's rlchain params) for the evaluation env: unchanged without an ``env`` or
    ``env_config`` override; otherwise a copy whose ``env_name`` builds the overriding env (registered once per
    call: the algorithm keeps the answer)."""
    overrides = settings.get("evaluation_config") or {}
    if not isinstance(overrides, dict) or ("env" not in overrides and "env_config" not in overrides):
        return params
    env = overrides.get("env", settings.get("env"))
    make, label = envs.env_maker(env, evaluation_env_config(settings), 0, 1)
    name = envs.register(make, f"{label} (evaluation_config)")
    return dataclasses.replace(params, config=dataclasses.replace(params.config, env_name=name, env_config={}))


def evaluation_env_config(settings: dict[str, Any]) -> dict[str, Any]:
    """The evaluation envs' ``env_config``: the config's, with ``evaluation_config``'s merged in key by key (nested
    dicts too), as RLlib's ``environment(env_config=...)`` deep-updates it when it applies ``evaluation_config``."""
    env_config = copy.deepcopy(settings.get("env_config") or {})
    overrides = settings.get("evaluation_config") or {}
    deep_update(env_config, copy.deepcopy((overrides.get("env_config") if isinstance(overrides, dict) else None)
                                          or {}))
    return env_config


def evaluation_explore(settings: dict[str, Any]) -> bool:
    """Whether evaluation samples its actions: ``evaluation_config``'s ``explore``, else the config's (RLlib's
    default True), as RLlib's evaluation env runners read it from the config merged with ``evaluation_config``."""
    overrides = settings.get("evaluation_config") or {}
    explore = overrides.get("explore") if isinstance(overrides, dict) and "explore" in overrides else None
    return bool(settings.get("explore", True) if explore is None else explore)
