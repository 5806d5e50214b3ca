"""MuJoCo Playground (JAX) envs as a tensor env: ``env_name: playground``, ``env_config.env_name: CartpoleBalance``.

Playground's envs are MJX (MuJoCo in JAX) envs with brax's ``reset``/``step`` shape, so they run
through the same jitted batch as the Brax adapter (``jax_batch.JaxBatchVecEnv``): every env steps
in one jitted call with same-step auto-reset, ``final_obs`` and a terminated/truncated split, and
tensors reach torch through DLPack.

``env_config`` keys: ``env_name`` (any ``mujoco_playground.registry.ALL_ENVS`` name),
``episode_length`` and ``action_repeat`` (the env's Playground default when left out; they set the
time limit of brax's ``EpisodeWrapper`` as Playground's own training does), ``impl`` (``jax``
here by default; ``warp`` needs an NVIDIA GPU), ``config_overrides`` (a dict of Playground config
keys, dotted for nested ones, e.g. ``{ctrl_dt: 0.02}``) and ``device`` (the torch device).

The DM-control-suite envs (CartpoleBalance, PendulumSwingup, CheetahRun, ...) ship their XML in
the package. The locomotion and manipulation envs need MuJoCo Menagerie's robot assets, which
Playground ``git clone``s on first use; without network access that fails and rlchain says so in
one line. Dict observations (locomotion envs: ``state`` and ``privileged_state``) are reduced to
their ``state`` entry (flattened); ``privileged_state`` is not used. Playground's domain
randomisation is not applied. Install: ``pip install rlchain[playground]``.
"""

from __future__ import annotations

import math
import subprocess
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.envs.backends.jax_batch import JaxBatchVecEnv
from rlchain.errors import did_you_mean

INSTALL_HINT = "MuJoCo Playground is not installed: pip install rlchain[playground] (or pip install playground)"
OPTIONS = ("episode_length", "action_repeat", "impl", "config_overrides", "device")


def import_registry() -> Any:
    """``mujoco_playground.registry``, or an ImportError naming the extra."""
    try:
        from mujoco_playground import registry
    except ImportError as exc:
        raise ImportError(INSTALL_HINT) from exc
    return registry


def check_name(registry: Any, name: str) -> None:
    """ValueError (one line, with a did-you-mean) unless ``name`` is a Playground registry name."""
    if name not in registry.ALL_ENVS:
        raise ValueError(f"MuJoCo Playground has no env '{name}'{did_you_mean(name, registry.ALL_ENVS)} "
                         f"(the names are mujoco_playground.registry.ALL_ENVS, e.g. CartpoleBalance)")


def has_key(config: Any, dotted: str) -> bool:
    """Whether the (nested) Playground ConfigDict ``config`` has the dotted key ``dotted``."""
    node = config
    for part in str(dotted).split("."):
        if not hasattr(node, "keys") or part not in node.keys():
            return False
        node = node[part]
    return True


def needs_menagerie(registry: Any, name: str) -> bool:
    """Locomotion and manipulation envs load robots from MuJoCo Menagerie (DM-control ones do not)."""
    return name in registry.locomotion.ALL_ENVS or name in registry.manipulation.ALL_ENVS


def menagerie_message(name: str, error: BaseException) -> str:
    """The one-line 'Menagerie assets missing' error for env ``name`` (the download failed with ``error``)."""
    from mujoco_playground._src import mjx_env

    return (f"MuJoCo Playground env '{name}' needs the MuJoCo Menagerie robot assets, which Playground "
            f"downloads on first use (git clone https://github.com/deepmind/mujoco_menagerie.git into "
            f"{mjx_env.MENAGERIE_PATH}, commit {mjx_env.MENAGERIE_COMMIT_SHA[:12]}) and that download failed "
            f"({type(error).__name__}: {str(error).splitlines()[0] if str(error) else 'no message'}): run once with "
            f"network access, or clone it there yourself; the DM-control envs (e.g. CartpoleBalance) need no download")


def observation_picker(observation_size: Any) -> tuple[int, Any]:
    """(flat obs size, a function from the env's obs to the (N, size) array): dict obs keep ``state``."""
    if isinstance(observation_size, int) or (hasattr(observation_size, "__len__")
                                             and not hasattr(observation_size, "keys")):
        shape = (observation_size,) if isinstance(observation_size, int) else tuple(observation_size)
        if len(shape) == 1:
            return int(shape[0]), lambda obs: obs
        size = math.prod(shape)
        return size, lambda obs: obs.reshape(obs.shape[0], size)
    if "state" not in observation_size:
        raise ValueError(f"dict observations without a 'state' entry are not supported "
                         f"(entries: {', '.join(sorted(observation_size))})")
    entry = observation_size["state"]
    size = math.prod((entry,) if isinstance(entry, int) else tuple(entry))
    return size, lambda obs: obs["state"].reshape(obs["state"].shape[0], size)


class UnknownConfigKey(KeyError):
    """A ``config_overrides`` key that the env's Playground config does not have."""


class PlaygroundVecEnv(JaxBatchVecEnv):
    """``num_envs`` copies of the Playground env ``name``, stepped together in JAX; torch tensors out."""

    def __init__(self, name: str, num_envs: int, seed: int | None = None, device: str = "cpu",
                 episode_length: int | None = None, action_repeat: int | None = None, impl: str | None = None,
                 config_overrides: dict | None = None) -> None:
        registry = import_registry()
        from brax.envs.wrappers.training import EpisodeWrapper, VmapWrapper

        check_name(registry, name)
        default = registry.get_default_config(name)
        overrides = dict(config_overrides or {})
        for key, value in (("episode_length", episode_length), ("action_repeat", action_repeat), ("impl", impl)):
            if value is not None and (has_key(default, key) or key == "impl"):  # no impl key: an error below
                overrides[key] = value
        if impl is None and "impl" not in overrides and has_key(default, "impl"):
            overrides["impl"] = "jax"  # Playground's DM-control default is warp, which needs an NVIDIA GPU
        for key in overrides:
            if not has_key(default, key):
                raise UnknownConfigKey(key)
        try:
            base = registry.load(name, config_overrides=overrides)
        except (subprocess.CalledProcessError, OSError) as exc:
            if needs_menagerie(registry, name):
                raise ValueError(menagerie_message(name, exc)) from None
            raise
        length = episode_length or overrides.get("episode_length") or default.get("episode_length", 1000)
        repeat = action_repeat or overrides.get("action_repeat") or default.get("action_repeat", 1)
        env = VmapWrapper(EpisodeWrapper(base, int(length), int(repeat)))
        obs_dim, obs_of = observation_picker(base.observation_size)
        key = ("playground", name, int(length), int(repeat), repr(sorted(overrides.items())))
        super().__init__(env, name, num_envs, obs_dim, int(base.action_size), seed, device, obs_of=obs_of,
                         build_key=key)


def playground_env(num_envs: int, seed: int | None, *, render: bool = False, **env_config: Any) -> PlaygroundVecEnv:
    """``env_name: playground``: the Playground env ``env_config.env_name``; the other keys are PlaygroundVecEnv's."""

    where = "params.config.env_config"
    if "env_name" not in env_config:
        raise ConfigError("", f"{where}.env_name", "is required with env_name playground "
                                                   "(a mujoco_playground.registry name, e.g. CartpoleBalance)")
    name = env_config.pop("env_name")
    for key in env_config:
        if key not in OPTIONS:
            raise ConfigError("", f"{where}.{key}", f"not a playground option (valid: env_name, "
                                                    f"{', '.join(OPTIONS)}){did_you_mean(key, OPTIONS)}")
    overrides = env_config.get("config_overrides")
    if overrides is not None and not isinstance(overrides, dict):
        raise ConfigError("", f"{where}.config_overrides", f"expected a mapping of Playground config keys, "
                                                           f"got {type(overrides).__name__}")
    try:
        return PlaygroundVecEnv(name, num_envs, seed, **env_config)
    except UnknownConfigKey as exc:
        key = exc.args[0]
        default = import_registry().get_default_config(name)
        raise ConfigError("", f"{where}.config_overrides.{key}",
                          f"not a config key of Playground's {name} (its keys: {', '.join(sorted(default.keys()))})"
                          ) from None
    except ValueError as exc:
        raise ConfigError("", f"{where}.env_name", str(exc)) from None
