"""EmbodiChain's task: ``trainer.learning_env`` or ``trainer.gym_config`` (a registered env name, or a
gym_config file whose ``id`` names one) -> rlchain's ``env_name`` and ``env_config``."""

from __future__ import annotations

import os
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.text import read_data
from rlchain.errors import did_you_mean
from rlchain.registry import ENVS


def resolve_env(trainer: dict, source: str) -> tuple[str, dict[str, Any]]:
    """``trainer.learning_env`` ({name, cfg} or a name) or ``trainer.gym_config`` (a registered env name, or a
    gym_config file whose ``id`` names one) -> (rlchain env_name, env_config)."""
    if "learning_env" in trainer and "gym_config" in trainer:
        raise ConfigError(source, "trainer.learning_env", "both learning_env and gym_config given; keep one")
    if "learning_env" in trainer:
        block = trainer["learning_env"]
        name, cfg = (block, {}) if isinstance(block, str) else (block.get("name"), dict(block.get("cfg") or {}))
        return _registered(str(name), "trainer.learning_env", source, None), cfg
    if "gym_config" not in trainer:
        raise ConfigError(source, "trainer.gym_config", "required key is missing (or give trainer.learning_env)")
    value = str(trainer["gym_config"])
    if value in ENVS:
        return value, {}
    path = _find_file(value, source)
    if path is None:
        if value.endswith((".json", ".yaml", ".yml")):
            raise ConfigError(source, "trainer.gym_config", f"file {value} not found (looked in the working "
                                                            "folder and above the config); or name a registered "
                                                            f"env{did_you_mean(value, ENVS.names())}")
        return _registered(value, "trainer.gym_config", source, None), {}
    data = read_data(path)
    if not isinstance(data, dict) or "id" not in data:
        raise ConfigError(path, "id", "a gym_config file names its task under 'id'")
    return _registered(str(data["id"]), "trainer.gym_config", source, path), {}


def _find_file(value: str, source: str) -> str | None:
    """``value`` relative to the working folder, else to each folder above the config file (EmbodiChain's
    paths are relative to its repository root)."""
    if os.path.isfile(value):
        return value
    folder = os.path.dirname(os.path.abspath(source)) if source and os.path.exists(source) else None
    while folder:
        candidate = os.path.join(folder, value)
        if os.path.isfile(candidate):
            return candidate
        parent = os.path.dirname(folder)
        folder = None if parent == folder else parent
    return None


def _registered(name: str, key: str, source: str, gym_config: str | None) -> str:
    if name in ENVS:
        return name
    lower = {n.lower(): n for n in ENVS.names()}
    if name.lower() in lower:  # EmbodiChain looks names up case-insensitively
        return lower[name.lower()]
    where = f" (the id in {gym_config})" if gym_config else ""
    raise ConfigError(source, key, f"task '{name}'{where} is not a registered env: EmbodiChain's DexSim tasks "
                                   "do not install here. Register a stand-in with @rlchain.envs.backends."
                                   f"embodichain_env.register_env('{name}'), or point {key} at a registered "
                                   f"env{did_you_mean(name, ENVS.names())}")
