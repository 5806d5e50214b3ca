"""Which algorithm's ``params.config`` class a key belongs to.

Every registered algorithm names its config class (``config_class``; PPO's :class:`PPOConfig` when it
names none). A ``params.config`` key that this run's algorithm does not read but another registered
algorithm's class declares (``tau`` with algo ``appo``: rl_games' own PPO YAML switched to appo) is
ignored with a one-line warning naming the file, the key, the algorithms it belongs to and why this one
ignores it (the class's ``other_algo_keys``). A key no registered algorithm knows stays a ConfigError with
a did-you-mean suggestion (:func:`rlchain.config.fields.parse_dataclass`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from rlchain.config import compat
from rlchain.config.errors import ConfigError
from rlchain.config.ppo import PPOConfig
from rlchain.errors import closest
from rlchain.registry import ALGOS


def config_class_of(algo: str) -> type:
    """The dataclass ``params.config`` of the registered algorithm ``algo`` parses into."""
    return getattr(ALGOS.get(algo), "config_class", PPOConfig)


def owners_of(key: str) -> list[str]:
    """The registered algorithms (sorted) whose config class has the key ``key``."""
    return [name for name in ALGOS.names() if key in _keys(config_class_of(name))]


def drop_other_algo_keys(config: dict[str, Any], algo: str, source: str, path: str = "params.config",
                         warn: bool = True) -> dict[str, Any]:
    """``config`` (a raw ``params.config`` mapping) without the keys that belong to another algorithm than
    ``algo``, each with a one-line warning when ``warn`` (False: warned about already). Unknown keys stay for
    the parser's error."""
    cls = config_class_of(algo)
    own = _keys(cls)
    out = dict(config)
    for key in config:
        if key in own:
            continue
        owners = owners_of(key)
        if not owners:
            _check_typo(key, own, algo, source, path)
            continue
        out.pop(key)
        if warn:
            why = getattr(cls, "other_algo_keys", {}).get(key)
            compat.warn_once(source, f"{path}.{key}", f"a key of algo {', '.join(owners)}, ignored by algo {algo}"
                                                      + (f": {why}" if why else ""))
    return out


def _check_typo(key: Any, own: set[str], algo: str, source: str, path: str) -> None:
    """A key in no algorithm's class that is close to none of this algo's keys but to another algo's
    (``taux`` with appo): the error suggests that key; otherwise the parser's did-you-mean applies."""
    if closest(key, sorted(own), n=1):
        return
    others = sorted({k for name in ALGOS.names() for k in _keys(config_class_of(name))} - own)
    close = closest(key, others, n=1)
    if close:
        raise ConfigError(source, f"{path}.{key}", f"unknown key; did you mean '{close[0]}'? (a key of algo "
                                                   f"{', '.join(owners_of(close[0]))}, ignored by algo {algo})")


def _keys(cls: type) -> set[str]:
    return {f.name for f in dataclasses.fields(cls) if f.init}
