"""Env names that come from a file (a checkpoint's stored config, an SB3-style model's ``env_id``), looked up in
the registries as they are, before anything can import.

Building an env from a name can import a module: gymnasium imports whatever precedes a ``:`` in an id
(``pkg.module:Env-v0``), the PettingZoo backend imports the module an env name gives. For a name the user wrote
(their ``--file``, a flag, an override, their Python call) that is their choice. A name read from a file is data:
it must already be a key of a registry this process holds -- gymnasium's registry dict (read, never
``gym.spec``), ale-py's ids (registered by importing ale-py itself), envpool's task list, PettingZoo's and mpe2's
env lists (:func:`rlchain.envs.backends.pettingzoo_env.known_env_names`), rlchain's
:data:`~rlchain.registry.ENVS` -- or it is refused in one line naming the file and the key. The backends whose
builders only look their names up in their own registries (brax, MuJoCo Playground, mjlab) and the envs and
``vecenv_type`` creators registered by code in this process take their names as they are.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym

from rlchain.config.errors import ConfigError
from rlchain.envs.backends.atari import import_ale
from rlchain.envs.backends.envpool_env import envpool_tasks
from rlchain.envs.backends.pettingzoo_env import known_env_names
from rlchain.registry import ENVS, VECENVS

GYM, ALE, ENVPOOL, PETTINGZOO = "gymnasium", "ale-py", "envpool", "PettingZoo"
NAMED_BY = {"openai_gym": ("name", GYM), "ray": ("name", GYM), "gymnasium": ("env_name", GYM),
            "atari_gym": ("name", ALE), "atari_gymnasium": ("env_name", ALE), "envpool": ("env_name", ENVPOOL),
            "pettingzoo": ("env", PETTINGZOO)}
"""rlchain's built-in envs that take the env's own name from ``env_config``: the key and the registry it is in."""
WRAPPED = "wrapped_env_name"
"""A gymnasium id an example env makes inside (rlchain.envs.examples.asymmetric): looked up in gymnasium's too."""
BLOCKS = ("env_config", "player.env_config")


def _gym_ids() -> Any:
    return gym.envs.registration.registry  # a dict: reading it imports nothing


def _ale_ids() -> Any:
    try:  # ale-py registers its ids when imported (a fixed module)
        import_ale()
    except ImportError:
        pass
    return _gym_ids()


def _envpool_ids() -> Any:
    try:
        return envpool_tasks()
    except ImportError:
        return frozenset()


LOOKUP: dict[str, Callable[[], Any]] = {GYM: _gym_ids, ALE: _ale_ids, ENVPOOL: _envpool_ids,
                                        PETTINGZOO: known_env_names}


def _get(config: dict[str, Any], dotted: str) -> Any:
    node: Any = config
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def stored_names(config: dict[str, Any]) -> list[tuple[str, Any, str]]:
    """``(key under params.config, value, registry)`` of every env name ``config`` (a ``params.config`` dict)
    would build with; empty when a ``vecenv_type`` registered by this process's code takes them."""
    vecenv = config.get("vecenv_type")
    if isinstance(vecenv, str) and vecenv.lower() not in ("auto", "sync", "async", "native", "envpool", "ray",
                                                          "gymnasium", "brax") \
            and (vecenv in VECENVS or vecenv.lower() in VECENVS):
        return []  # a user's creator (rl_games' vecenv.register): code of this process gets the names
    env_name = config.get("env_name")
    if env_name is None:
        return []  # no env to build: the config's own check says the key is missing
    if not isinstance(env_name, str):
        return [("env_name", env_name, GYM)]
    by_envpool = isinstance(vecenv, str) and vecenv.lower() == "envpool"
    if env_name in NAMED_BY:
        key, registry = NAMED_BY[env_name]
        return [(f"{block}.{key}", _get(config, f"{block}.{key}"), registry) for block in BLOCKS
                if isinstance(_get(config, block), dict) and key in _get(config, block)]
    entry = ENVS.get(env_name) if env_name in ENVS else {}
    if ("env_creator" in entry or "vecenv_creator" in entry) and not by_envpool:
        return []  # registered by code in this process; rlchain's own look their names up in their registries
    # an entry that only binds a vecenv_type (rl_games 2.0's config binding) leaves the name a gymnasium id
    names = [("env_name", env_name, ENVPOOL if by_envpool else GYM)]
    names += [(f"{block}.{WRAPPED}", _get(config, f"{block}.{WRAPPED}"), GYM) for block in BLOCKS
              if isinstance(_get(config, block), dict) and WRAPPED in _get(config, block)]
    return names


def check_stored_env(config: dict[str, Any], source: str, from_file: Callable[[str], bool],
                     path: str = "params.config", hint: str = "pass your own config (--file) to build another env"
                     ) -> None:
    """Refuse (one-line ConfigError naming ``source`` and the key) an env name of ``config`` that came from the
    file (``from_file(key)``) and is not a key of its registry as it is (see the module docstring)."""
    if not isinstance(config, dict):
        return  # not a config block: parsing it says so
    for key, value, registry in stored_names(config):
        if from_file(key):  # else the user's override: theirs to give
            check_listed(value, registry, source, f"{path}.{key}", hint)


def is_listed(value: Any, registry: str) -> bool:
    """Whether ``value`` is a key of ``registry`` (GYM, ALE, ENVPOOL or PETTINGZOO) as it is."""
    return isinstance(value, str) and value in LOOKUP[registry]()


def check_listed(value: Any, registry: str, source: str, key: str, hint: str) -> None:
    """A one-line ConfigError naming ``source`` and ``key`` unless ``value`` is listed by ``registry``."""
    if not is_listed(value, registry):
        shown = f"'{value[:80]}'" if isinstance(value, str) else repr(value)[:80]
        raise ConfigError(source, key, f"{shown} is not an env {registry} lists in this process; a name read "
                                       f"from a file is only looked up, never imported: {hint}")
