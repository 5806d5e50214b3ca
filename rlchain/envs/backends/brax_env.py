"""Brax (JAX) environments as a tensor env: ``env_name: brax``, ``env_config.env_name: ant``.

Brax steps a whole batch of envs inside one jitted JAX function, on the CPU here or on a GPU/TPU.
This adapter keeps everything on JAX's device and hands torch the arrays through DLPack, so
obs, rewards and done flags reach the trainer without a numpy round trip (the tensor-env contract
of ``docs/tensor_envs.md``). Per step it (``jax_batch.JaxBatchVecEnv``, shared with Playground):

- steps every env (``EpisodeWrapper``: episode time limit, ``info['truncation']`` on a time-out);
- auto-resets the finished rows in the same jitted call (``lax.cond``: the batched reset runs only
  on steps where some row ended), keeping their last observation as ``final_obs``;
- splits brax's ``done`` into ``terminated`` (the task ended) and ``truncated`` (time limit).

``env_config`` keys: ``env_name`` (a ``brax.envs`` name: ant, halfcheetah, hopper, humanoid,
inverted_pendulum, reacher, ...), ``episode_length`` (1000), ``action_repeat`` (1), ``backend``
(brax's default, or generalized / positional / spring / mjx) and ``device`` (the torch device the
tensors are on: ``cpu``, or ``cuda:N`` when JAX runs on that GPU). Install: ``pip install rlchain[brax]``.
"""

from __future__ import annotations

from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.envs.backends.jax_batch import JaxBatchVecEnv

INSTALL_HINT = "brax is not installed: pip install rlchain[brax] (or pip install brax)"


def import_brax() -> tuple[Any, Any, Any]:
    """(jax, jax.numpy, brax.envs), or an ImportError naming the extra."""
    try:
        import jax
        import jax.numpy as jnp
        from brax import envs
    except ImportError as exc:
        raise ImportError(INSTALL_HINT) from exc
    return jax, jnp, envs


class BraxVecEnv(JaxBatchVecEnv):
    """``num_envs`` copies of the brax env ``name``, stepped together in JAX; torch tensors out."""

    def __init__(self, name: str, num_envs: int, seed: int | None = None, device: str = "cpu",
                 episode_length: int = 1000, action_repeat: int = 1, backend: str | None = None) -> None:
        _, _, envs = import_brax()
        from brax.envs.wrappers.training import EpisodeWrapper, VmapWrapper

        if name not in envs._envs:
            raise ValueError(f"brax has no env '{name}' (known: {', '.join(sorted(envs._envs))})")
        kwargs = {} if backend is None else {"backend": backend}
        base = envs.get_environment(name, **kwargs)
        env = VmapWrapper(EpisodeWrapper(base, episode_length, action_repeat))
        super().__init__(env, name, num_envs, int(env.observation_size), int(env.action_size), seed, device,
                         build_key=("brax", name, int(episode_length), int(action_repeat), backend))


def brax_env(num_envs: int, seed: int | None, *, render: bool = False, **env_config: Any) -> BraxVecEnv:
    """``env_name: brax``: the brax env ``env_config.env_name``; the other keys are BraxVecEnv's."""

    if "env_name" not in env_config:
        raise ConfigError("", "params.config.env_config.env_name", "is required with env_name brax "
                                                                   "(a brax.envs name, e.g. ant)")
    name = env_config.pop("env_name")
    allowed = {"episode_length", "action_repeat", "backend", "device"}
    for key in env_config:
        if key not in allowed:
            raise ConfigError("", f"params.config.env_config.{key}",
                              f"not a brax option (valid: env_name, {', '.join(sorted(allowed))})")
    try:
        return BraxVecEnv(name, num_envs, seed, **env_config)
    except ValueError as exc:
        raise ConfigError("", "params.config.env_config.env_name", str(exc)) from None
