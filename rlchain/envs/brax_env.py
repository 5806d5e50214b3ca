"""Brax (JAX) environments as a tensor env: ``env_name: brax``, ``env_config.env_name: ant``.

Brax steps a whole batch of envs inside one jitted JAX function, on the CPU here or on a GPU/TPU.
This adapter keeps everything on JAX's device and hands torch the arrays through DLPack, so
obs, rewards and done flags reach the trainer without a numpy round trip (the tensor-env contract
of ``docs/tensor_envs.md``). Per step it:

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

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.vecenv import StepResult

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


class BraxVecEnv:
    """``num_envs`` copies of the brax env ``name``, stepped together in JAX; torch tensors out."""

    is_tensor_env = True

    def __init__(self, name: str, num_envs: int, seed: int | None = None, device: str = "cpu",
                 episode_length: int = 1000, action_repeat: int = 1, backend: str | None = None) -> None:
        jax, jnp, envs = import_brax()
        from brax.envs.wrappers.training import EpisodeWrapper, VmapWrapper

        if name not in envs._envs:
            raise ValueError(f"brax has no env '{name}' (known: {', '.join(sorted(envs._envs))})")
        kwargs = {} if backend is None else {"backend": backend}
        base = envs.get_environment(name, **kwargs)
        env = VmapWrapper(EpisodeWrapper(base, episode_length, action_repeat))
        self.name, self.num_envs, self.device = name, num_envs, torch.device(device)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (int(env.observation_size),), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (int(env.action_size),), np.float32)
        self._jax, self._jnp = jax, jnp
        self._key = jax.random.PRNGKey(0 if seed is None else int(seed))
        self._reset_fn = jax.jit(env.reset)

        def step(state: Any, action: Any, key: Any) -> tuple:
            """One step of every env; ended rows take a fresh state (same-step auto-reset)."""
            nxt = env.step(state, action)
            done = nxt.done.astype(bool)
            trunc = nxt.info["truncation"].astype(bool) & done

            def reset_done(_: Any) -> Any:
                fresh = env.reset(jax.random.split(key, num_envs))
                # keep the running episode's metrics/counters layout: fresh rows where done
                fresh = fresh.replace(info={**nxt.info, **{k: v for k, v in fresh.info.items() if k in nxt.info}})

                def pick(a: Any, b: Any) -> Any:
                    if not hasattr(a, "shape") or a.shape[:1] != done.shape:
                        return b
                    return jnp.where(done.reshape(done.shape + (1,) * (a.ndim - 1)), a, b)
                return jax.tree_util.tree_map(pick, fresh, nxt)

            merged = jax.lax.cond(done.any(), reset_done, lambda _: nxt, None)
            return merged, nxt.obs, nxt.reward, done & ~trunc, trunc

        self._step_fn = jax.jit(step)
        self._state: Any = None

    def _torch(self, array: Any) -> torch.Tensor:
        """A JAX array as a torch tensor on ``device`` (shared memory through DLPack where it can)."""
        return torch.from_dlpack(array).to(self.device)

    def reset(self, seed: int | None = None) -> torch.Tensor:
        """Reset every env (from ``seed`` when given); obs (N, obs_dim) float32 on ``device``."""
        jax = self._jax
        if seed is not None:
            self._key = jax.random.PRNGKey(int(seed))
        self._key, sub = jax.random.split(self._key)
        self._state = self._reset_fn(jax.random.split(sub, self.num_envs))
        return self._torch(self._state.obs).float()

    def step(self, actions: torch.Tensor) -> StepResult:
        """Step with actions (N, act_dim) in [-1, 1] (a torch tensor); every field a tensor on ``device``."""
        jax, jnp = self._jax, self._jnp
        self._key, sub = jax.random.split(self._key)
        action = jnp.from_dlpack(actions.detach().float().contiguous().cpu()
                                 if self.device.type == "cpu" else actions.detach().float().contiguous())
        self._state, final, reward, terminated, truncated = self._step_fn(self._state, action, sub)
        return StepResult(self._torch(self._state.obs).float(), self._torch(reward).float(),
                          self._torch(terminated).bool(), self._torch(truncated).bool(),
                          self._torch(final).float(), {})

    def close(self) -> None:
        """Nothing to release (JAX frees the arrays)."""
        self._state = None


def brax_env(num_envs: int, seed: int | None, *, render: bool = False, **env_config: Any) -> BraxVecEnv:
    """``env_name: brax``: the brax env ``env_config.env_name``; the other keys are BraxVecEnv's."""
    from rlchain.config.errors import ConfigError

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
