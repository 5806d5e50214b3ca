"""RLlib's ``env_to_module_connector`` read as a setting: a function returning ``MeanStdFilter()`` (RLlib's tuned
Pendulum example; APPO and IMPALA; ``multi_agent=True`` on a MultiAgentEnv: per policy) is rlchain's observation
normalizer; ``FlattenObservations()`` (alone or beside it) asks for nothing, the face's observations being flat
already; any other connector is a one-line error.

RLlib's filter folds every observation into running statistics as the env runners see it and hands the module
``(obs - mean) / std`` clipped to +-``clip_by_value`` (10). rlchain's ``normalize_input`` with
``obs_normalizer_update: step`` folds each env step's observations in as they come and normalizes as
``(obs - mean) / sqrt(var + 1e-5)`` clipped to +-5; the training pass reads the raw observations through the
statistics of its update (RLlib trains on the observations as they were filtered while sampling).
"""

from __future__ import annotations

import inspect
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.rllib.connectors.env_to_module.flatten_observations import FlattenObservations
from rlchain.rllib.connectors.env_to_module.mean_std_filter import MeanStdFilter

KEY = "env_to_module_connector"

NORMALIZE = {"normalize_input": True, "obs_normalizer": "rl_games", "obs_normalizer_update": "step"}
"""rlchain's ``params.config`` keys for RLlib's ``MeanStdFilter``."""

NORMALIZE_VTRACE = {"normalize_input": True, "obs_normalizer": "rl_games"}
"""... for APPO and IMPALA: rlchain's learner folds each batch's observations into the statistics before its
update and hands them to the runners with the weights (RLlib's runners fold every step in and merge their filters
each iteration)."""

NORMALIZE_MULTI_AGENT = {"normalize_input": True, "obs_normalizer": "rl_games", "obs_normalizer_update": "auto"}
"""... for ``MeanStdFilter(multi_agent=True)`` (a MultiAgentEnv): RLlib keeps statistics per agent; rlchain's
multi-policy PPO keeps them per policy (the same where each agent has its own policy, as in RLlib's multi-agent
examples) and folds each rollout's observations in before its update, not every step as it comes."""


def _connectors(config: Any, make: Any) -> list[Any]:
    """What RLlib's ``env_to_module_connector`` function returns (called as RLlib calls it: ``(env, spaces,
    device)``, else ``(env)``; the face passes no env), as a list."""
    try:
        arity = len(inspect.signature(make).parameters)
    except (TypeError, ValueError):
        arity = 3
    try:
        out = make(None, None, None) if arity >= 3 else make(None)
    except Exception as exc:
        raise ConfigError(type(config).__name__, KEY, f"calling it with (env, spaces, device) failed: "
                                                      f"{type(exc).__name__}: {exc}") from None
    return list(out) if isinstance(out, (list, tuple)) else [out]


def filter_keys(config: Any) -> dict[str, Any]:
    """rlchain's keys for the config's ``env_to_module_connector`` ({} without one): ``MeanStdFilter()`` with its
    defaults under PPO is ``normalize_input``, ``FlattenObservations()`` adds no key (every observation reaches the
    networks flattened); anything else is a one-line ConfigError."""
    make = config._settings.get(KEY)
    if make is None:
        return {}
    name = type(config).__name__
    if not callable(make):
        raise ConfigError(name, KEY, f"expected a function (env, spaces, device) -> connector, got {make!r}")
    items = _connectors(config, make)
    if not items or not all(isinstance(c, (MeanStdFilter, FlattenObservations)) for c in items):
        raise ConfigError(name, KEY, f"{items!r}: the face maps only MeanStdFilter() (rlchain's normalize_input) "
                                     f"and FlattenObservations() (its observations are flat already); preprocess "
                                     f"observations in a gymnasium wrapper")
    items = [c for c in items if isinstance(c, MeanStdFilter)]
    if not items:
        return {}
    if config.algo_name not in ("PPO", "APPO", "IMPALA"):
        raise ConfigError(name, KEY, f"MeanStdFilter is mapped for PPO, APPO and IMPALA, not {config.algo_name}")
    for f in items:
        if not (f.de_mean_to_zero and f.de_std_to_one and f.update_stats):
            raise ConfigError(name, KEY, f"MeanStdFilter(de_mean_to_zero={f.de_mean_to_zero}, de_std_to_one="
                                         f"{f.de_std_to_one}, update_stats={f.update_stats}, multi_agent="
                                         f"{f.multi_agent}): only its defaults map onto normalize_input")
    if config.algo_name != "PPO":
        return dict(NORMALIZE_VTRACE)
    if any(f.multi_agent for f in items):
        return dict(NORMALIZE_MULTI_AGENT)
    return dict(NORMALIZE)
