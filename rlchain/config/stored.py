"""A config read from a checkpoint, as data: shapes and hyperparameters only.

A checkpoint is a file from anywhere; the person running the command is the only one who can ask for code
to run or trust to be given. So the config stored inside a checkpoint loses every key that names code to
import, a folder to follow or trust to grant before rlchain reads it (``Runner.load_from_checkpoint``, the
SB3-style ``load``): the user's own config (``--file``), flags and overrides bring those back on purpose.
"""

from __future__ import annotations

import copy
from typing import Any

from rlchain.config.errors import ConfigError

# params.config keys dropped from a stored config: each names code (callbacks, event functions, a mirror map's
# module:function, an observer), a folder to watch, or grants trust to the files read later.
DROPPED_CONFIG_KEYS = ("trust_checkpoint", "callbacks", "events", "algo_observer", "symmetry")
DROPPED_PLAYER_KEYS = ("evaluation", "dir_to_monitor")

def as_data(raw: dict[str, Any], source: str) -> tuple[dict[str, Any], list[str]]:
    """``raw`` (``{'params': ...}`` from a checkpoint) without the keys that name code, folders or trust, and
    the key paths dropped (for one warning line). The env names it keeps are data too: the caller looks them
    up in the registries (:func:`rlchain.envs.known.check_stored_env`) once the user's overrides are applied."""
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
    policies = params.get("policies")
    if isinstance(policies, dict):
        for name, policy in policies.items():
            if isinstance(policy, dict):
                _strip_params(policy, f"{path}.policies.{name}", dropped, source)
