"""A config read from a checkpoint, as data: shapes and hyperparameters only.

A checkpoint is a file from anywhere; the person running the command is the only one who can ask for code
to run or trust to be given. So the config stored inside a checkpoint loses every key that names code to
import, a folder to follow or trust to grant before rlchain reads it (``Runner.load_from_checkpoint``, the
SB3-style ``load``): the user's own config (``--file``), flags and overrides bring those back on purpose.
"""

from __future__ import annotations

import copy
import re
from typing import Any

from rlchain.config.errors import ConfigError

# params.config keys dropped from a stored config: each names code (callbacks, event functions, a mirror map's
# module:function, an observer), a folder to watch, or grants trust to the files read later.
DROPPED_CONFIG_KEYS = ("trust_checkpoint", "callbacks", "events", "algo_observer", "symmetry")
DROPPED_PLAYER_KEYS = ("evaluation", "dir_to_monitor")

# gymnasium imports the module of an id written "package.module:EnvName-v0"; a stored env name may not
_IMPORTING_ID = re.compile(r"^\s*[A-Za-z_][\w.]*\s*:\s*[A-Za-z_][\w.\-/]*\s*$")
ENV_NAME_KEYS = ("name", "env_name", "id", "env_id", "wrapped_env_name", "task")


def as_data(raw: dict[str, Any], source: str) -> tuple[dict[str, Any], list[str]]:
    """``raw`` (``{'params': ...}`` from a checkpoint) without the keys that name code, folders or trust, and
    the key paths dropped (for one warning line). An env name that would import a module (``pkg:Env-v0``)
    is a one-line ConfigError: the checkpoint cannot say which env to build without the user's config."""
    params = raw.get("params") if isinstance(raw, dict) else None
    if not isinstance(params, dict):  # another layout (EmbodiChain's) would be translated, events and all
        raise ConfigError(source, "params", "the stored config has no 'params' block; pass the config it was "
                                            "trained with (--file)")
    out = {"params": copy.deepcopy(params)}  # only the rl_games-style block: nothing else is read
    dropped: list[str] = []
    _strip_params(out["params"], "params", dropped, source)
    return out, dropped


def _strip_params(params: dict[str, Any], path: str, dropped: list[str], source: str) -> None:
    if params.pop("import_modules", None):
        dropped.append(f"{path}.import_modules")
    config = params.get("config")
    if isinstance(config, dict):
        for key in DROPPED_CONFIG_KEYS:
            if config.pop(key, None) not in (None, False, [], {}, ""):
                dropped.append(f"{path}.config.{key}")
        player = config.get("player")
        if isinstance(player, dict):
            for key in DROPPED_PLAYER_KEYS:
                if player.pop(key, None) not in (None, False, ""):
                    dropped.append(f"{path}.config.player.{key}")
        _check_env_names(config, f"{path}.config", source)
    policies = params.get("policies")
    if isinstance(policies, dict):
        for name, policy in policies.items():
            if isinstance(policy, dict):
                _strip_params(policy, f"{path}.policies.{name}", dropped, source)


def _check_env_names(config: dict[str, Any], path: str, source: str) -> None:
    """Refuse an env id that makes gymnasium import a module, in env_name and the env_config's name keys."""
    named = [("env_name", config.get("env_name"))]
    player = config.get("player")
    blocks = {"env_config": config.get("env_config"),
              "player.env_config": player.get("env_config") if isinstance(player, dict) else None}
    for block, value in blocks.items():
        if isinstance(value, dict):
            named += [(f"{block}.{k}", value.get(k)) for k in ENV_NAME_KEYS]
    for key, value in named:
        check_env_id(value, source, f"{path}.{key}")


def check_env_id(value: Any, source: str, key: str) -> None:
    """A stored env id that would make gymnasium import a module (``package.module:Env-v0``) is refused."""
    if isinstance(value, str) and _IMPORTING_ID.match(value):
        raise ConfigError(source, key, f"'{value}' would import module '{value.split(':')[0].strip()}' named "
                                       f"by the checkpoint; a checkpoint's config is data: pass your own config "
                                       f"(--file) or env to build this env")
