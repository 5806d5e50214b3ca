"""Stable-Baselines3's ``.zip`` model files, read as data: ``rlchain.PPO.load("ppo_cartpole.zip")``.

An SB3 archive holds ``data`` (JSON: hyperparameters, and every object SB3 could not write as JSON as a
cloudpickled ``:serialized:`` string beside its readable attributes), ``policy.pth`` (the policy's state dict)
and the optimizers' states. Only the JSON's plain values and readable attributes and ``policy.pth`` (through
:func:`rlchain.runs.checkpoint.read_zip_member`, ``weights_only``) are read; nothing cloudpickled is ever
unpickled. The spaces are rebuilt from their JSON fields (``dtype``, ``_shape``, ``low``, ``high``, ``n``,
``start``), a schedule from its constant value, the network's layer sizes from the weights' shapes.
MlpPolicy only (PPO with separate actor and critic layers, SAC with 2 critics, DQN). A SAC trained with gSDE
(``use_sde``) plays its mean as SB3 does (the clip of its mean kept); its noise becomes rlchain's Gaussian.
Archives of SB3 < 2 (old ``gym`` spaces, as rl-baselines3-zoo's published models) read the same way.
"""

from __future__ import annotations

import inspect
import json
import math
import re
import zipfile
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.config.text import MAX_NESTING, depth_of
from rlchain.runs import archive
from rlchain.runs import checkpoint as ckpt
from rlchain.sb3.defaults import SB3_DEFAULTS
from rlchain.sb3.names import is_sb3_named

HYPERPARAMETERS = {
    "ppo": ("learning_rate", "n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda", "clip_range", "ent_coef",
            "vf_coef", "max_grad_norm", "normalize_advantage"),
    "sac": ("learning_rate", "buffer_size", "learning_starts", "batch_size", "tau", "gamma", "ent_coef"),
    "dqn": ("learning_rate", "buffer_size", "learning_starts", "batch_size", "tau", "gamma", "target_update_interval",
            "exploration_fraction", "exploration_initial_eps", "exploration_final_eps", "max_grad_norm"),
}
"""The SB3 arguments taken from an archive (numbers; a constant schedule's value) for training further."""

DEFAULT_ACTIVATION = {"ppo": "Tanh", "sac": "ReLU", "dqn": "ReLU"}
SDE_CLIP_MEAN = 2.0  # SB3's default clip_mean of the gSDE SAC actor
SDE_LOG_STD_BOUNDS = tuple(float(b) for b in SB3_DEFAULTS["sac"]["network"]["log_std_bounds"])
"""The log-std bounds of the SAC a loaded archive builds (its log-std head goes through rlchain's soft bound)."""
MAX_ELEMENTS = 1 << 24
"""The most elements a space's shape may have (16.8M: a 3 x 2048 x 2048 image is 12.6M)."""
MAX_TIMESTEPS, MAX_ENVS = 2**62, 1 << 16
"""Bounds of the archive's ``num_timesteps`` and ``n_envs``."""
FIRST_LAYER = {"ppo": ("mlp_extractor.policy_net.0.weight", "action_net.weight"),
               "sac": ("actor.latent_pi.0.weight", "actor.mu.weight", "actor.mu.0.weight"),
               "dqn": ("q_net.q_net.0.weight",)}
"""The weight of the policy's first layer (hidden layers, else the output layer), whose inputs are the observation's."""


@dataclass(frozen=True)
class SB3Archive:
    """What rlchain takes from an SB3 archive."""

    observation_space: gym.Space
    action_space: gym.Space
    hyperparameters: dict[str, Any]  # SB3 names -> numbers
    policy_kwargs: dict[str, Any]  # net_arch (from the weights), activation_fn (a name)
    policy_state: dict[str, Any]  # SB3-named tensors
    num_timesteps: int
    n_envs: int
    seed: int | None


def is_sb3_archive(path: str) -> bool:
    """Whether ``path`` is a zip with SB3's ``data`` and ``policy.pth``."""
    return ckpt.is_sb3_layout(path)


def _array(text: Any, shape: tuple[int, ...], path: str, key: str) -> np.ndarray:
    """A numpy array from its repr in the JSON (``'[-1. -1. -8.]'``)."""
    if isinstance(text, (list, int, float)):
        return np.asarray(text, dtype=np.float64).reshape(shape)
    if not isinstance(text, str) or "..." in text:
        raise ckpt.CheckpointError(f"{path}: {key} is not readable from the archive's JSON ({str(text)[:60]!r})")
    values = np.array([float(v) for v in re.sub(r"[\[\]\n,]", " ", text).split()], dtype=np.float64)
    if values.size == 1 and int(np.prod(shape)) != 1:
        values = np.full(shape, values[0])
    return values.reshape(shape)


def _shape(entry: dict[str, Any]) -> tuple[int, ...]:
    """A space's shape: ``_shape`` (a list; gymnasium) or ``shape`` (the text ``'[4]'``; the gym of SB3 < 2,
    which rl-baselines3-zoo's published models were saved with), checked before anything of that shape is
    allocated: at most :data:`MAX_ELEMENTS` elements."""
    shape = entry["_shape"] if "_shape" in entry else entry["shape"]
    if isinstance(shape, str):
        shape = [int(v) for v in re.sub(r"[\[\]()]", " ", shape[:200]).replace(",", " ").split()]
    if not isinstance(shape, (list, tuple)) or len(shape) > 8 or \
            not all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in shape):
        raise ValueError(f"shape {str(shape)[:60]}: expected up to 8 sizes >= 0")
    if math.prod(shape) > MAX_ELEMENTS:
        raise ValueError(f"shape {list(shape)} has {math.prod(shape)} elements; rlchain reads spaces of at most "
                         f"{MAX_ELEMENTS} (far above any real observation)")
    return tuple(shape)


def _space(entry: Any, path: str, key: str) -> gym.Space:
    """A Box, Discrete or MultiDiscrete space from its JSON fields."""
    kind = str(entry.get(":type:", "")) if isinstance(entry, dict) else ""
    try:
        if kind.endswith(".Box'>"):
            shape = _shape(entry)
            dtype = np.dtype(str(entry["dtype"])[:20])
            if dtype.kind not in "biuf" or dtype.itemsize > 8:
                raise ValueError(f"dtype {dtype}: expected a number type")
            return gym.spaces.Box(_array(entry["low"], shape, path, f"{key}.low").astype(dtype),
                                  _array(entry["high"], shape, path, f"{key}.high").astype(dtype), shape, dtype)
        if kind.endswith(".Discrete'>"):
            return gym.spaces.Discrete(int(entry["n"]), start=int(entry.get("start", 0)))
        if kind.endswith(".MultiDiscrete'>"):
            nvec = _array(entry["nvec"], _shape(entry), path, f"{key}.nvec")
            return gym.spaces.MultiDiscrete(nvec.astype(np.int64))
    except (KeyError, TypeError, ValueError, OverflowError) as exc:
        raise ckpt.CheckpointError(f"{path}: {key} is malformed in the archive ({type(exc).__name__}: "
                                   f"{' '.join(str(exc).split())[:160]})") from None
    named = " ".join(kind.split())[:80] or type(entry).__name__  # the file's text, kept to one short line
    raise ckpt.CheckpointError(f"{path}: {key}: a {named} space; rlchain reads Box, "
                               f"Discrete and MultiDiscrete from SB3 archives")


def _number(value: Any) -> float | int | bool | str | None:
    """A plain JSON value, or a constant schedule's value (``FloatSchedule(ConstantSchedule(val=0.2))``);
    None for anything else (a serialized function)."""
    if isinstance(value, (int, float, bool, str)):
        return value
    if isinstance(value, dict):
        for field in ("value_schedule", "val"):
            match = re.search(r"val=([-+0-9.eE]+)", str(value.get(field, "")))
            if match:
                return float(match.group(1))
    return None


def _hyperparameter(value: Any, path: str, key: str) -> Any:
    """An archive's hyperparameter as SB3 writes it: a finite number, a bool (normalize_advantage) or SAC's
    ``ent_coef`` ``'auto'`` / ``'auto_0.1'``; anything else is a one-line CheckpointError naming the key."""
    if isinstance(value, bool):
        if key == "normalize_advantage":
            return value
    elif isinstance(value, (int, float)) and math.isfinite(value):
        return value
    if key == "ent_coef" and isinstance(value, str) and re.fullmatch(r"auto(_[0-9.eE+-]+)?", value):
        return value
    raise ckpt.CheckpointError(f"{path}: {key}: expected a number, got {str(value)[:40]!r} ({type(value).__name__})")


def _layers(state: dict[str, Any], prefix: str) -> list[int]:
    """Hidden layer sizes of the ``nn.Sequential`` at ``prefix`` (Linear at even positions)."""
    found = sorted((int(m.group(1)), v.shape[0]) for k, v in state.items()
                   if (m := re.fullmatch(re.escape(prefix) + r"\.(\d+)\.weight", k)))
    return [size for _, size in found]


def _architecture(algo: str, state: dict[str, Any], path: str) -> list[int]:
    """The hidden layer sizes of the archive's MlpPolicy, checked to be one rlchain builds."""
    if any(k.startswith(("features_extractor.", "pi_features_extractor.", "actor.features_extractor.")) and
           not k.endswith("running_mean") for k in state):
        raise ckpt.CheckpointError(f"{path}: the policy has a features extractor with weights (CnnPolicy?); "
                                   f"rlchain reads MlpPolicy archives")
    if algo == "ppo":
        pi, vf = _layers(state, "mlp_extractor.policy_net"), _layers(state, "mlp_extractor.value_net")
        if pi != vf or any(k.startswith("mlp_extractor.shared_net") for k in state):
            raise ckpt.CheckpointError(f"{path}: actor layers {pi} and critic layers {vf} differ or share layers; "
                                       f"rlchain's MlpPolicy has the same separate layers for both")
        return pi
    if algo == "sac":
        pi, qf = _layers(state, "actor.latent_pi"), _layers(state, "critic.qf0")[:-1]
        if "actor.log_std.weight" not in state or "critic.qf2.0.weight" in state or pi != qf:
            raise ckpt.CheckpointError(f"{path}: rlchain reads SAC archives with 2 critics and the "
                                       f"same layers for actor and critics (actor {pi}, critic {qf})")
        return pi
    return _layers(state, "q_net.q_net")[:-1]


def _sde_actor(state: dict[str, Any], path: str) -> dict[str, Any]:
    """A gSDE SAC actor's tensors as a plain SAC actor's: the mean layer ``actor.mu.0`` (before SB3's Hardtanh)
    becomes ``actor.mu``; the gSDE noise matrix ``actor.log_std`` (latent, actions) becomes a state-independent
    log-std head (zero weights, bias its mean over the latent units, through rlchain's soft bound). The mean,
    hence the deterministic action, is SB3's exactly; exploration noise when training further is rlchain's."""
    if "actor.mu.0.weight" not in state or getattr(state.get("actor.log_std"), "ndim", 0) != 2:
        raise ckpt.CheckpointError(f"{path}: a use_sde SAC archive without actor.mu.0 and a 2-d actor.log_std")
    out = {k: v for k, v in state.items() if k != "actor.log_std" and not k.startswith("actor.mu.")}
    weight, bias = state["actor.mu.0.weight"], state["actor.mu.0.bias"]
    out["actor.mu.weight"], out["actor.mu.bias"] = weight, bias
    low, high = SDE_LOG_STD_BOUNDS
    target = state["actor.log_std"].float().mean(0).clamp(low + 1e-3, high - 1e-3)
    out["actor.log_std.weight"] = weight.new_zeros(weight.shape)
    out["actor.log_std.bias"] = torch.atanh(2 * (target - low) / (high - low) - 1).to(bias.dtype)
    return out


def _activation(policy_kwargs: Any, algo: str) -> str:
    """The torch.nn activation class name of ``policy_kwargs['activation_fn']`` read from its JSON attributes
    (``'<function ReLU.forward at ...>'``), else SB3's default for ``algo``."""
    entry = policy_kwargs.get("activation_fn") if isinstance(policy_kwargs, dict) else None
    if isinstance(entry, dict):
        for value in entry.values():
            match = re.match(r"<function (\w+)\.forward", str(value))
            if match:
                return match.group(1)
    return DEFAULT_ACTIVATION[algo]


def read_sb3_archive(path: str, algo: str) -> SB3Archive:
    """The :class:`SB3Archive` of an SB3 ``algo`` (ppo, sac, dqn) model file; one-line CheckpointErrors."""
    data = read_data(path)
    state = ckpt.read_zip_member(path, "policy.pth")
    if not isinstance(state, dict) or not is_sb3_named(algo, state):
        raise ckpt.CheckpointError(f"{path}: its policy is not an SB3 {algo.upper()} MlpPolicy")
    sde = bool(data.get("use_sde"))
    if sde and algo != "sac":
        raise ckpt.CheckpointError(f"{path}: a {algo.upper()} trained with use_sde; rlchain reads gSDE archives of "
                                   f"SAC only")
    if sde:
        state = _sde_actor(state, path)
    hyper = {k: _hyperparameter(v, path, k) for k in HYPERPARAMETERS[algo] if (v := _number(data.get(k))) is not None}
    kwargs = {"net_arch": _architecture(algo, state, path),
              "activation_fn": _activation(data.get("policy_kwargs"), algo)}
    if sde:  # SB3's gSDE actor ends its mean with Hardtanh(-clip_mean, clip_mean)
        clip = _number((data.get("policy_kwargs") or {}).get("clip_mean")) if isinstance(
            data.get("policy_kwargs"), dict) else None
        kwargs["clip_mean"] = float(clip) if isinstance(clip, (int, float)) and not isinstance(clip, bool) \
            else SDE_CLIP_MEAN
    if algo == "sac":  # SB3 keeps the learned entropy coefficient outside the policy
        names = zipfile.ZipFile(path).namelist()
        member = next((m for m in ("pytorch_variables.pth", "tensors.pth") if m in names), None)  # tensors: SB3 < 1
        variables = ckpt.read_zip_member(path, member) if member else {}
        if isinstance(variables, dict) and "log_ent_coef" in variables:
            state = {**state, "log_alpha": variables["log_ent_coef"].detach().reshape(())}
    observation_space = _space(data.get("observation_space"), path, "observation_space")
    _check_inputs(algo, state, observation_space, path)
    return SB3Archive(observation_space, _space(data.get("action_space"), path, "action_space"), hyper, kwargs, state,
                      count(data.get("num_timesteps"), path, "num_timesteps", 0, MAX_TIMESTEPS, 0),
                      count(data.get("n_envs"), path, "n_envs", 1, MAX_ENVS, 1),
                      count(data.get("seed"), path, "seed", -(2**63), 2**63 - 1, None))


def read_data(path: str) -> dict[str, Any]:
    """The archive's ``data`` JSON as a dict, read within bounds (:data:`~rlchain.runs.archive.DATA_LIMIT`,
    :data:`~rlchain.config.text.MAX_NESTING` levels: a config's bound); anything else is a one-line CheckpointError."""
    try:
        raw = archive.read_member(path, "data", archive.DATA_LIMIT)
    except archive.ArchiveError as exc:
        raise ckpt.CheckpointError(str(exc)) from None
    try:
        data = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise ckpt.CheckpointError(f"{path}: 'data' is not UTF-8 text (byte {exc.start}): not SB3's JSON") from None
    except json.JSONDecodeError as exc:
        raise ckpt.CheckpointError(f"{path}: 'data' is not JSON ({exc.msg} at line {exc.lineno} column "
                                   f"{exc.colno})") from None
    except RecursionError:
        raise ckpt.CheckpointError(f"{path}: 'data' nests deeper than {MAX_NESTING} levels: not SB3's JSON") from None
    if not isinstance(data, dict):
        raise ckpt.CheckpointError(f"{path}: 'data' is a JSON {type(data).__name__}, not the object SB3 writes")
    if depth_of(data) > MAX_NESTING:
        raise ckpt.CheckpointError(f"{path}: 'data' nests deeper than {MAX_NESTING} levels: not SB3's JSON")
    return data


def count(value: Any, path: str, key: str, low: int, high: int, default: int | None) -> int | None:
    """An integer field of the archive (``num_timesteps``, ``n_envs``, ``seed``) in ``low .. high``; ``default``
    when absent; anything else is a one-line CheckpointError naming the file and the key."""
    if value is None:
        return default
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ckpt.CheckpointError(f"{path}: {key}: expected an integer in {low} .. {high}, got "
                                   f"{str(value)[:40]!r} ({type(value).__name__})")
    return value


def _check_inputs(algo: str, state: dict[str, Any], space: gym.Space, path: str) -> None:
    """The policy's first layer must take the observation space's flat size (a network is never built for more
    inputs than the file's weights have)."""
    for key in FIRST_LAYER[algo]:
        weight = state.get(key)
        if getattr(weight, "ndim", 0) == 2:
            size = int(gym.spaces.flatdim(space))
            if int(weight.shape[1]) != size:
                raise ckpt.CheckpointError(f"{path}: the policy's first layer ({key}) takes {int(weight.shape[1])} "
                                           f"inputs, the observation_space {size}: the archive is inconsistent")
            return


class _SpacesEnv(gym.Env):
    """An env that only has the spaces: what SB3's constructor needs to build a model to write."""

    def __init__(self, observation_space: gym.Space, action_space: gym.Space) -> None:
        self.observation_space, self.action_space = observation_space, action_space

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict]:
        return self.observation_space.sample(), {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        return self.observation_space.sample(), 0.0, True, False, {}


def write_sb3_archive(path: str, algo: str, spaces: tuple[gym.Space, gym.Space], hyperparameters: dict[str, Any],
                      net_arch: list[int], activation: type, policy_state: dict[str, Any], num_timesteps: int) -> str:
    """SB3's own ``.zip`` of a model with SB3's MlpPolicy layout, written by SB3 (``model.save``) from the same
    arguments and ``policy_state`` (SB3-named), so SB3's ``load`` reads it. Needs stable-baselines3."""
    try:  # optional: stable-baselines3 writes its own format (its cloudpickled entries included)
        import stable_baselines3
        from stable_baselines3.common.vec_env import DummyVecEnv
    except ImportError as exc:
        raise ModuleNotFoundError(f"{path}: writing SB3's .zip layout needs stable-baselines3 (pip install "
                                  f"stable-baselines3); save to a .pth path for rlchain's own file") from exc
    cls = getattr(stable_baselines3, algo.upper())
    accepted = set(inspect.signature(cls).parameters)
    kwargs = {k: v for k, v in hyperparameters.items() if k in accepted and k not in ("policy", "env")}
    env = DummyVecEnv([lambda: _SpacesEnv(*spaces)])
    model = cls("MlpPolicy", env, device="cpu", policy_kwargs={"net_arch": list(net_arch), "activation_fn": activation},
                **kwargs)
    missing = set(model.policy.state_dict()) - set(policy_state)
    if missing:
        raise ValueError(f"{path}: the model's network is not SB3's MlpPolicy layout (no {sorted(missing)[0]}); "
                         f"SB3's .zip needs SB3's defaults' network (defaults='sb3')")
    model.policy.load_state_dict({k: v for k, v in policy_state.items() if k in model.policy.state_dict()})
    model.num_timesteps = int(num_timesteps)
    model.save(path)
    return path
