"""Snapshot and restore one gymnasium env (its whole wrapper chain), for exact resume.

A gymnasium env is a chain of layers (wrappers, then the unwrapped env). :func:`snapshot` walks the
chain and keeps, per layer:

- ``attrs``: every attribute holding plain data (numbers, strings, numpy arrays and scalars, and
  tuples / lists / deques / dicts of them; gymnasium's ``RunningMeanStd``): TimeLimit's elapsed
  steps, OrderEnforcing's flag, frame-stack queues, normalization filters, a classic-control
  env's ``state``, copied;
- ``generators``: the state of every numpy ``Generator`` / ``RandomState`` (the env's ``np_random``);
- ``mujoco``: MuJoCo's full integration state (``mj_getState(mjSTATE_INTEGRATION)``: time, qpos,
  qvel, act, warm start, controls, applied forces, mocap) when the layer has ``model`` / ``data``.

Attributes of a few known kinds carry no state of their own (spaces, the env spec, the MuJoCo model
and renderer, methods, the link to the wrapped env). Any other attribute (an emulator handle, a
physics engine object rlchain cannot read) makes :func:`snapshot` raise :class:`StateUnavailable`
naming it: an env is restored entirely or reported as not restored, never half-restored silently.
"""

from __future__ import annotations

import copy
import types
from collections import deque
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import EnvSpec as GymEnvSpec
from gymnasium.wrappers.utils import RunningMeanStd

from rlchain.envs.vecenv import StateUnavailable

_PLAIN = (bool, int, float, complex, str, bytes, type(None), np.ndarray, np.generic, RunningMeanStd)
_LINKS = ("env", "_env", "envs", "unwrapped")  # the wrapped env(s): walked, not copied
_CONSTANT = frozenset(("_saved_kwargs", "_ezpickle_args", "_ezpickle_kwargs", "metadata", "_metadata", "fullpath",
                       "observation_structure", "render_mode", "_disable_render_order_enforcing"))
"""Attributes gymnasium sets once at construction (how the env was made, what it renders): not copied."""


def _is_plain(value: Any, depth: int = 0) -> bool:
    """Whether ``value`` is data a deep copy restores exactly (no handles, no generators)."""
    if isinstance(value, _PLAIN):
        return True
    if depth > 4:
        return False
    if isinstance(value, (tuple, list, deque)):
        return all(_is_plain(v, depth + 1) for v in value)
    if isinstance(value, dict):
        return all(isinstance(k, (str, int)) and _is_plain(v, depth + 1) for k, v in value.items())
    return False


def _copy(value: Any) -> Any:
    """A copy of plain data (see :func:`_is_plain`) that shares nothing mutable with ``value``: immutable
    values as they are, arrays copied, containers rebuilt (cheaper than ``copy.deepcopy``)."""
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, (bool, int, float, complex, str, bytes, type(None), np.generic)):
        return value
    if isinstance(value, tuple):
        return tuple(_copy(v) for v in value)
    if isinstance(value, list):
        return [_copy(v) for v in value]
    if isinstance(value, deque):
        return deque((_copy(v) for v in value), maxlen=value.maxlen)
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    return copy.deepcopy(value)  # RunningMeanStd


def _stateless(value: Any) -> bool:
    """Attributes of kinds that hold no episode state: spaces, specs, MuJoCo's model and renderer, code."""
    if isinstance(value, (gym.Space, GymEnvSpec, types.FunctionType, types.MethodType, type)):
        return True
    name = type(value).__name__
    return name in ("MjModel", "MujocoRenderer") or callable(value) and not hasattr(value, "__dict__")


def _mujoco_pair(layer: Any) -> tuple[Any, Any] | None:
    model, data = vars(layer).get("model"), vars(layer).get("data")
    if type(model).__name__ == "MjModel" and type(data).__name__ == "MjData":
        return model, data
    return None


def layers(env: Any) -> list[Any]:
    """The chain from ``env`` (outermost) down to the unwrapped env."""
    chain = [env]
    while isinstance(getattr(chain[-1], "__dict__", {}).get("env"), (gym.Env, gym.vector.VectorEnv)):
        chain.append(vars(chain[-1])["env"])
    return chain


def _layer_snapshot(layer: Any, where: str) -> dict[str, Any]:
    attrs, generators = {}, {}
    pair = _mujoco_pair(layer)
    for key, value in vars(layer).items():
        if key in _LINKS or key in _CONSTANT:
            continue
        if isinstance(value, np.random.Generator):
            generators[key] = copy.deepcopy(value.bit_generator.state)
        elif isinstance(value, np.random.RandomState):
            generators[key] = value.get_state()
        elif _is_plain(value):
            attrs[key] = _copy(value)
        elif pair is not None and key == "data":
            continue
        elif not _stateless(value):
            raise StateUnavailable(f"{where} ({type(layer).__name__}) holds '{key}' of type "
                                   f"{type(value).__name__}, which rlchain cannot snapshot")
    state: dict[str, Any] = {"type": type(layer).__name__, "attrs": attrs, "generators": generators}
    if pair is not None:
        import mujoco
        model, data = pair
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        buf = np.empty(mujoco.mj_stateSize(model, spec), dtype=np.float64)
        mujoco.mj_getState(model, data, buf, spec)
        state["mujoco"] = buf
    return state


def snapshot(env: Any, where: str = "env") -> list[dict[str, Any]]:
    """The state of every layer of ``env`` (see the module docstring); StateUnavailable when a layer
    holds something that cannot be copied."""
    return [_layer_snapshot(layer, where) for layer in layers(env)]


def restore(env: Any, state: list[dict[str, Any]], where: str = "env") -> None:
    """Put ``state`` (from :func:`snapshot` of an env of the same chain) back into ``env``."""
    chain = layers(env)
    kinds = [type(layer).__name__ for layer in chain]
    saved = [layer["type"] for layer in state]
    if kinds != saved:
        raise ValueError(f"{where}: the saved env state is for layers {saved}, this env has {kinds}")
    for layer, layer_state in zip(chain, state):
        for key, value in layer_state["attrs"].items():
            setattr(layer, key, _copy(value))
        for key, gen_state in layer_state["generators"].items():
            gen = vars(layer).get(key)
            if isinstance(gen, np.random.RandomState) or isinstance(gen_state, tuple):
                if not isinstance(gen, np.random.RandomState):
                    gen = np.random.RandomState()
                    setattr(layer, key, gen)
                gen.set_state(gen_state)
                continue
            if not isinstance(gen, np.random.Generator):
                bit = getattr(np.random, gen_state["bit_generator"])()
                gen = np.random.Generator(bit)
                setattr(layer, key, gen)
            gen.bit_generator.state = copy.deepcopy(gen_state)
        if "mujoco" in layer_state:
            import mujoco
            model, data = _mujoco_pair(layer)
            mujoco.mj_setState(model, data, np.asarray(layer_state["mujoco"], dtype=np.float64),
                               mujoco.mjtState.mjSTATE_INTEGRATION)
            mujoco.mj_forward(model, data)  # derived quantities (positions, sensors) of the restored state
