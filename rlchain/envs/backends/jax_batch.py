"""A batch of JAX envs as one tensor env: the jitted step, auto-reset and DLPack hand-off.

Brax (``env_name: brax``) and MuJoCo Playground (``env_name: playground``) envs share one shape:
``reset(keys) -> State`` and ``step(state, action) -> State`` where ``State`` is a flax struct with
``obs``, ``reward``, ``done`` and an ``info`` dict, and brax's ``VmapWrapper(EpisodeWrapper(env))``
batches them and adds the episode time limit (``info['truncation']``). ``JaxBatchVecEnv`` takes such
a wrapped env and, per ``step``:

- steps every env in one jitted call;
- auto-resets the finished rows in the same call (``lax.cond``: the batched reset runs only on
  steps where some row ended), keeping their last observation as ``final_obs``;
- splits ``done`` into ``terminated`` (the task ended) and ``truncated`` (the time limit);
- hands obs, rewards and flags to torch through DLPack, without a numpy round trip.

The adapters (``brax_env.py``, ``playground_env.py``) only build and wrap their env.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from rlchain.envs.vecenv import StepResult

if TYPE_CHECKING:  # torch is imported where it is used: a Ray env worker of numpy envs never needs it
    import torch


class JaxBatchVecEnv:
    """``num_envs`` copies of a wrapped JAX env, stepped together in one jitted call; torch tensors out.

    ``env`` is ``VmapWrapper(EpisodeWrapper(base))`` (brax's training wrappers); ``obs_dim`` and
    ``action_dim`` are the flat sizes; ``obs_of`` maps the env's observation (an array, or a dict
    for some Playground envs) to the (N, obs_dim) array the trainer sees, inside the jitted step.
    """

    is_tensor_env = True

    def __init__(self, env: Any, name: str, num_envs: int, obs_dim: int, action_dim: int,
                 seed: int | None = None, device: str = "cpu",
                 obs_of: Callable[[Any], Any] = lambda obs: obs) -> None:
        import jax
        import jax.numpy as jnp
        import torch

        self.name, self.num_envs, self.device = name, num_envs, torch.device(device)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (int(obs_dim),), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (int(action_dim),), np.float32)
        self._jax, self._jnp = jax, jnp
        self._key = jax.random.PRNGKey(0 if seed is None else int(seed))

        def strong(tree: Any) -> Any:
            """Every array leaf of ``tree`` strongly typed (same dtype; free once compiled).

            A brax env's step can compute ``done`` from Python floats (inverted_pendulum:
            ``jnp.where(..., 1.0, 0.0)``), so ``done`` and the flags EpisodeWrapper derives from it
            (``info['truncation']``, ``info['episode_done']``, ``info['time_out']``) come out
            *weakly* typed float32, while the reset made them strong. The jitted step's cache key
            includes weak types, so the second step (fed the step's state, not the reset's)
            compiled the whole step again (~10-20 s on CPU). Reset and step both hand back strong
            leaves, so the step compiles once."""
            return jax.tree_util.tree_map(lambda x: x.astype(x.dtype) if hasattr(x, "dtype") else x, tree)

        def reset(keys: Any) -> tuple:
            state = strong(env.reset(keys))
            return state, obs_of(state.obs)

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

            merged = strong(jax.lax.cond(done.any(), reset_done, lambda _: nxt, None))
            return merged, obs_of(merged.obs), obs_of(nxt.obs), nxt.reward, done & ~trunc, trunc

        self._reset_fn = jax.jit(reset)
        self._step_fn = jax.jit(step)
        self._state: Any = None

    def _torch(self, array: Any) -> torch.Tensor:
        """A JAX array as a torch tensor on ``device`` (shared memory through DLPack where it can)."""
        import torch

        return torch.from_dlpack(array).to(self.device)

    def reset(self, seed: int | None = None) -> torch.Tensor:
        """Reset every env (from ``seed`` when given); obs (N, obs_dim) float32 on ``device``."""
        jax = self._jax
        if seed is not None:
            self._key = jax.random.PRNGKey(int(seed))
        self._key, sub = jax.random.split(self._key)
        # committed keys give a committed state: the step's cache key then matches from the first
        # step on (an uncommitted reset state made the second step compile the step function again)
        keys = jax.device_put(jax.random.split(sub, self.num_envs), jax.devices()[0])
        self._state, obs = self._reset_fn(keys)
        return self._torch(obs).float()

    def step(self, actions: torch.Tensor) -> StepResult:
        """Step with actions (N, act_dim) in [-1, 1] (a torch tensor); every field a tensor on ``device``."""
        jax, jnp = self._jax, self._jnp
        self._key, sub = jax.random.split(self._key)
        action = jnp.from_dlpack(actions.detach().float().contiguous().cpu()
                                 if self.device.type == "cpu" else actions.detach().float().contiguous())
        self._state, obs, final, reward, terminated, truncated = self._step_fn(self._state, action, sub)
        return StepResult(self._torch(obs).float(), self._torch(reward).float(),
                          self._torch(terminated).bool(), self._torch(truncated).bool(),
                          self._torch(final).float(), {})

    def get_state(self) -> dict[str, Any]:
        """The batch's JAX state pytree (physics, episode counters and metrics in ``info``) and the
        random key (exact resume; the VecEnv contract's optional ``get_state``), as plain data: the
        pytree's leaves as numpy arrays with each one's weak type, so a checkpoint holds no JAX or env
        classes (it loads as data); :meth:`set_state` rebuilds the pytree on this env's own structure."""
        jax = self._jax
        if self._state is None:
            self.reset()
        leaves = jax.tree_util.tree_leaves(self._state)
        return {"leaves": [np.asarray(x) if hasattr(x, "shape") else x for x in leaves],
                "weak_types": [bool(getattr(getattr(x, "aval", None), "weak_type", False)) for x in leaves],
                "key": np.asarray(self._key)}

    def set_state(self, state: dict[str, Any]) -> None:
        """Put back :meth:`get_state`'s result: the leaves committed to JAX's device as a reset's state is
        (with their weak types, which the jitted step's cache key includes), the key uncommitted as a fresh
        one is, so the restored env runs the step already compiled."""
        jax = self._jax
        if self._state is None:
            self.reset()
        own, treedef = jax.tree_util.tree_flatten(self._state)
        leaves, weak = state["leaves"], state.get("weak_types") or [False] * len(state["leaves"])
        if len(leaves) != len(own):
            raise ValueError(f"the saved state has {len(leaves)} arrays, this env's {len(own)}: saved from "
                             f"another env or env_config")
        device = jax.devices()[0]

        def put(value: Any, is_weak: bool) -> Any:
            if not hasattr(value, "shape"):
                return value
            array = jax.device_put(value, device)
            if is_weak:  # as JAX's own unpickling does: numpy has no weak types
                array.aval = array.aval.update(weak_type=True)
            return array
        self._state = jax.tree_util.tree_unflatten(treedef, [put(v, w) for v, w in zip(leaves, weak)])
        # the key stays uncommitted, as PRNGKey makes it: a committed key gives a committed ``sub``, and the
        # step's cache key (which includes each argument's committedness) would miss, compiling it again
        self._key = self._jnp.asarray(np.asarray(state["key"]))

    def close(self) -> None:
        """Nothing to release (JAX frees the arrays)."""
        self._state = None
