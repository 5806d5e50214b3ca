"""ONNX export of a trained policy: ``runner.py --export onnx --file cfg.yaml --checkpoint X.pth``.

The exported graph is the deterministic policy as the Player runs it::

    obs (batch, *obs_shape) float32 | uint8  ->  action (batch, *action_shape), value (batch, value_size)

- ``obs``: float32, or uint8 when the observation space is uint8 (scaled to [0, 1] inside the graph,
  as :meth:`ActorCritic.preprocess` does). Input normalization (the model's RunningMeanStd, frozen
  statistics) is part of the graph: feed raw env observations.
- ``action``: the distribution's mode, post-processed for the env (``Distribution.to_env``):
  int64 argmax of the logits for Discrete, (batch, K) int64 argmax per dimension for MultiDiscrete /
  Tuple of Discrete; for Box the mean, clipped to [-1, 1] and rescaled to the space's bounds when
  ``clip_actions`` is on (float32).
- ``value``: the critic's value on the return scale (value normalization undone).
- Observations with the previous reward and action (``use_dict_obs_space`` / ``wrap_impala``, see
  rlchain/envs/wrappers/reward_action_obs.py): ``obs`` is the env's flat float32 vector
  ``[last action one-hot | frames scaled to [0, 1] | reward clipped to [-1, 1]]``; build it the same way.

- A model that reads an observation group (``config.obs_groups``: a distilled student, PPO on
  ``obs_groups.policy``): ``obs`` is the group's features alone, in the group's order (e.g. the
  student's joint positions without the teacher's velocities); see docs/distillation.md.
- Recurrent policies (``network.rnn``): the graph also takes the RNN states ``rnn_state_0``,
  ``rnn_state_1`` (LSTM h and c; GRU has one), each (layers, batch, units), zeros at an episode
  start, and returns the next ones as ``rnn_state_0_out`` ... after action and value. Feed them
  back every step and zero an env's rows when its episode ends.
- Masked policies (``use_action_masks: True``): the graph also takes ``action_mask``
  (batch, mask_size) **bool**, True where an action is allowed: the env's ``get_action_mask()`` as
  the Player passes it (mask_size = n for Discrete(n), sum(nvec) for multi-discrete, the
  per-dimension masks concatenated). Masked-out logits are set to ``MASKED_LOGIT`` before the argmax,
  as in training, so the action is always an allowed one; a row (or dimension) with no allowed action
  is not checked in the graph and gets its first action. bool, not uint8: it is what the env returns
  and onnxruntime takes numpy bool arrays as they are (cast a 0/1 array with ``.astype(bool)``).
  Policies without masks have no such input.

- Dict observations kept per key (a ``multi_input`` network): one input per key in place of ``obs``, named
  after the key (``image``, ``proprio``, ...) in the space's order, each in its own dtype (uint8 images are
  scaled inside the graph, vector keys normalized there as in training; a Discrete key is an int64 input,
  the env's value, looked up in the embedding inside the graph).

Input order: ``obs`` (or the Dict's keys), then the RNN states (if any), then ``action_mask`` (if any); outputs:
``action``, ``value``, then the next RNN states. Feed by name (:class:`OnnxPolicy` holds the names).
The batch axis is dynamic (axis 1 of the states). Requires ``pip install rlchain[onnx]`` (onnx + onnxruntime).
"""

from __future__ import annotations

import contextlib
import copy
import os
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn

from rlchain.config.errors import ConfigError
from rlchain.envs.obs_dict import ObsDict, flat_size, is_dict_space, obs_as_tensor, torch_dtype
from rlchain.errors import optional_import
from rlchain.inference.export.inputs import (  # noqa: F401  (re-exported: the parity inputs)
    HUGE_BOUND,
    RANDOM_OBS_BOUND,
    env_observations,
    env_rollout,
    random_masks,
    random_observations,
)
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.normalization import dict_as_float
from rlchain.policy.load import load_policy

INSTALL_HINT = "pip install rlchain[onnx]"


def _require(module: str) -> Any:
    """Import ``onnx`` / ``onnxruntime`` or fail with the install hint."""
    return optional_import(module, f"ONNX export needs onnx and onnxruntime ('{module}' is not installed): "
                                   f"{INSTALL_HINT}")


class OnnxPolicy(nn.Module):
    """Export wrapper: ``forward(obs, *states, [action_mask]) -> (action, value, *new_states)``.

    Names are class attributes so callers (export, verification, deployments) agree on them.
    Recurrent policies extend ``state_names``: each state ``s`` becomes an input ``s`` and an output
    ``s + '_out'``, appended after obs / after (action, value). A ``use_action_masks`` policy takes
    ``mask_name`` (``mask_dtype``, (batch, mask_size)) last, so the positional order of the graph
    without masks does not change.
    """

    state_names: tuple[str, ...] = ()
    mask_name: str = "action_mask"
    mask_dtype: torch.dtype = torch.bool
    """bool: what ``get_action_mask()`` returns; onnxruntime takes numpy bool arrays as they are."""

    def __init__(self, model: ActorCritic, obs_keys: tuple[str, ...] = ()) -> None:
        super().__init__()
        self.model = model
        self.obs_keys = tuple(obs_keys)  # Dict observations: one graph input per key
        initial = model.initial_state(1, torch.device("cpu")) if getattr(model, "is_rnn", False) else ()
        self.state_names = tuple(f"rnn_state_{i}" for i in range(len(initial)))
        self.uses_masks = bool(getattr(model, "use_action_masks", False))
        self.mask_size = int(model.dist.mask_size) if self.uses_masks else 0

    @property
    def input_names(self) -> list[str]:
        """The graph's inputs in order: ``obs``, the RNN states (if any), ``action_mask`` (if used)."""
        return [*(self.obs_keys or ["obs"]), *self.state_names, *([self.mask_name] if self.uses_masks else [])]

    @property
    def output_names(self) -> list[str]:
        """The graph's outputs in order: ``action``, ``value``, then ``<state>_out`` per RNN state."""
        return ["action", "value", *(f"{s}_out" for s in self.state_names)]

    def forward(self, obs: torch.Tensor, *inputs: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """``inputs``: the other keys' observations (Dict), the RNN states in ``state_names`` order, then the
        action mask when used."""
        if self.obs_keys:
            keys = len(self.obs_keys)
            obs, inputs = ObsDict(dict(zip(self.obs_keys, (obs, *inputs[:keys - 1])))), inputs[keys - 1:]
        states = inputs[:len(self.state_names)]
        if self.state_names:
            params, value, new_states = self.model.evaluate(obs, states)
        else:  # every model (PPO, SAC, DQN) maps obs -> (dist params, value)
            (params, value), new_states = self.model(obs), ()
        dist = self.model.dist
        if self.uses_masks:  # the training-time masking, without the data-dependent validity check
            params = dist.mask(params, inputs[len(self.state_names)], check=False)
        action = dist.to_env(dist.mode(params))
        return (action, self.model.denorm_value(value), *(new_states or ()))

    def initial_state(self, batch: int) -> tuple[torch.Tensor, ...]:
        """Zero RNN states (each (layers, batch, units)) to feed the first step; empty without an RNN."""
        return tuple(self.model.initial_state(batch, torch.device("cpu"))) if self.state_names else ()

    def dummy_inputs(self, obs: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """(obs, zero states, all-True mask): example inputs for tracing, in ``input_names`` order."""
        batch = obs.shape[0]
        mask = (torch.ones(batch, self.mask_size, dtype=self.mask_dtype),) if self.uses_masks else ()
        keys = tuple(obs[k] for k in self.obs_keys) if self.obs_keys else (obs,)
        return (*keys, *self.initial_state(batch), *mask)


def obs_dtype(space: gym.Space) -> torch.dtype:
    """The exported graph's input dtype: uint8 for uint8 Box observations, else float32."""
    dtype = getattr(space, "dtype", None)
    return torch.uint8 if dtype is not None and np.dtype(dtype) == np.uint8 else torch.float32


def export_model_onnx(model: ActorCritic, obs_shape: tuple[int, ...] | gym.spaces.Dict, output_path: str,
                      opset: int = 17, input_dtype: torch.dtype = torch.float32) -> str:
    """Export ``model``'s deterministic policy (see the module docstring) to ``output_path``.

    ``input_dtype``: torch.uint8 for image observations (the graph scales them), else float32. ``obs_shape``
    a Dict space: one input per key, each in its space's dtype (int64 for a Discrete / MultiDiscrete key).
    The model is copied to the CPU in eval mode; the caller's model is not changed. Returns the path.
    """
    _require("onnx")
    keys = tuple(obs_shape.spaces) if isinstance(obs_shape, gym.spaces.Dict) else ()
    policy = OnnxPolicy(copy.deepcopy(model).cpu().eval(), keys)
    if keys:
        # a Discrete key's lowest value is its start (0 may be no value of it: the embedding would fail)
        dummy = policy.dummy_inputs(ObsDict({k: torch.zeros((2, *s.shape), dtype=torch_dtype(s))
                                             + torch.as_tensor(getattr(s, "start", 0), dtype=torch_dtype(s))
                                             for k, s in obs_shape.spaces.items()}))
    else:
        dummy = policy.dummy_inputs(torch.zeros((2, *obs_shape), dtype=input_dtype))
    folder = os.path.dirname(os.path.abspath(output_path))
    os.makedirs(folder, exist_ok=True)
    states = set(policy.state_names) | {f"{s}_out" for s in policy.state_names}
    dynamic = {name: {1 if name in states else 0: "batch"} for name in policy.input_names + policy.output_names}
    with warnings.catch_warnings(), torch.no_grad():
        # torch >= 2.9 marks the TorchScript-based exporter deprecated; it needs no onnxscript and
        # handles this feed-forward graph exactly
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.filterwarnings("ignore", message=".*legacy TorchScript-based ONNX export.*")
        # nn.LSTM/GRU's own shape checks trace as constants; the states are graph inputs (tested)
        warnings.filterwarnings("ignore", category=torch.jit.TracerWarning)
        warnings.filterwarnings("ignore", message=".*batch_size other than 1.*")
        torch.onnx.export(policy, dummy, output_path, dynamo=False, opset_version=opset,
                          input_names=policy.input_names, output_names=policy.output_names,
                          dynamic_axes=dynamic, do_constant_folding=True)
    onnx = _require("onnx")
    onnx.checker.check_model(onnx.load(output_path))
    return output_path


def onnx_session(onnx_path: str) -> Any:
    """An onnxruntime CPU inference session for ``onnx_path``."""
    ort = _require("onnxruntime")
    return ort.InferenceSession(onnx_path, providers=["CPUExecutionProvider"])


ONNX_NUMPY = {"tensor(uint8)": np.uint8, "tensor(int64)": np.int64}
"""A graph input's type -> the numpy dtype it is fed in (float32 for any other)."""


def verify_onnx(model: ActorCritic, onnx_path: str, obs_batch: Any, session: Any = None,
                steps: int = 3, masks: Any = None, seed: int = 0) -> float:
    """Max abs difference between onnxruntime and PyTorch (every output) on ``obs_batch``.

    ``obs_batch``: (B, *obs_shape) numpy array or tensor, cast to the graph's input dtype. Discrete
    actions count as a difference of at least 1 when the argmax differs. A recurrent policy runs
    ``steps`` steps from zero states, each graph fed its own returned states, so the state path is
    compared too. A masked policy gets ``masks`` (B, mask_size) bool, by default
    :func:`random_masks` (``seed``), on both sides.
    """
    session = session or onnx_session(onnx_path)
    inputs = {i.name: i for i in session.get_inputs()}
    keys = tuple(obs_batch) if isinstance(obs_batch, dict) else ()
    arrays = {k: np.ascontiguousarray(torch.as_tensor(np.asarray(v) if not isinstance(v, torch.Tensor) else v)
                                      .cpu().numpy()).astype(ONNX_NUMPY.get(getattr(inputs.get(k), "type", ""),
                                                                            np.float32))
              for k, v in (obs_batch.items() if keys else [("obs", obs_batch)])}
    graph_input = session.get_inputs()[0]
    obs = arrays[keys[0] if keys else "obs"]
    policy = OnnxPolicy(copy.deepcopy(model).cpu().eval(), keys)
    mask_feed: dict = {}
    if policy.uses_masks:
        masks = random_masks(model.dist, obs.shape[0], seed) if masks is None else masks
        mask_feed = {policy.mask_name: np.ascontiguousarray(torch.as_tensor(masks).cpu().bool().numpy())}
    torch_mask = tuple(torch.from_numpy(m) for m in mask_feed.values())
    torch_states = policy.initial_state(obs.shape[0])
    onnx_states = [s.numpy() for s in torch_states]
    diff = 0.0
    for _ in range(steps if policy.state_names else 1):
        # a key the network leaves out (encoder: none) is no graph input: torch.onnx prunes unused inputs
        obs_feed = {k: a for k, a in arrays.items() if k in inputs} if keys else {graph_input.name: obs}
        feed = {**obs_feed, **dict(zip(policy.state_names, onnx_states)),
                **mask_feed}
        onnx_out = session.run(policy.output_names, feed)
        with torch.no_grad():
            torch_out = policy(*(torch.from_numpy(a) for a in arrays.values()), *torch_states, *torch_mask)
        for got, want in zip(onnx_out, torch_out):
            want = want.numpy()
            if got.shape != want.shape:
                raise RuntimeError(f"ONNX output shape {got.shape} differs from PyTorch's {want.shape}")
            if got.size:
                diff = max(diff, float(np.max(np.abs(got.astype(np.float64) - want.astype(np.float64)))))
        onnx_states = onnx_out[2:]
        torch_states = tuple(torch_out[2:])
    return diff


def _load(params: Any, checkpoint_path: str, num_envs: int = 1) -> tuple[ActorCritic, Any]:
    """Checkpoint + env + model on the CPU, as the Player builds them. Returns (model, env)."""

    policy = load_policy(params, checkpoint_path, device=torch.device("cpu"), num_envs=num_envs,
                         env_config=params.config.player.env_config)
    return policy.model, policy.env


def exported_view(model: ActorCritic, space: gym.Space) -> tuple[ActorCritic, tuple[int, ...], torch.dtype, Any]:
    """What the graph is built on: a model that reads an ``obs_groups`` group (a distilled student, PPO on
    ``obs_groups.policy``) is exported on its view alone -- the graph's ``obs`` is the group's features in the
    group's order, so a deployment feeds only what the student sees. Returns (the model to export, the
    graph's obs shape, its dtype, a function mapping the env's observations to the graph's input)."""
    if is_dict_space(space) and not getattr(model, "flatten_dict", False):  # one input per key
        return model, space, torch.float32, lambda obs: obs
    if is_dict_space(space):  # a flat-input network on a Dict: the graph takes the keys concatenated
        size = flat_size(space)
        return model, (size,), torch.float32, lambda obs: dict_as_float(obs_as_tensor(obs, "cpu")).flatten(1).numpy()
    if getattr(model, "obs_group", None) is None or model.obs_slice is None:
        return model, tuple(space.shape), obs_dtype(space), lambda obs: obs
    alone = copy.deepcopy(model)
    alone.obs_slice, alone.obs_group = None, None
    size = int(model.view(torch.zeros((1, *space.shape))).shape[1])

    def take(obs: Any) -> np.ndarray:
        return model.view(torch.as_tensor(np.asarray(obs, dtype=np.float32))).numpy()

    return alone, (size,), torch.float32, take


def default_output_path(checkpoint_path: str) -> str:
    """``nn/cartpole.pth`` -> ``nn/cartpole.onnx``."""
    return os.path.splitext(checkpoint_path)[0] + ".onnx"


def export_onnx(params: Any, checkpoint_path: str, output_path: str | None = None, opset: int = 17) -> str:
    """Build the config's model, load ``checkpoint_path`` into it and export it; returns the path.

    ``params``: validated :class:`rlchain.config.params.Params` (``Runner.load(...).params``). A bad
    checkpoint raises the same CheckpointError as play; missing onnx packages an ImportError.
    """
    _require("onnx")
    _require("onnxruntime")
    output_path = output_path or default_output_path(checkpoint_path)
    model, env = _load(params, checkpoint_path)
    try:
        graph_model, shape, dtype, _ = exported_view(model, env.observation_space)
        return export_model_onnx(graph_model, shape, output_path, opset, dtype)
    finally:
        env.close()


def export_from_cli(runner: Any, checkpoint: str | None, output: str | None = None, opset: int = 17,
                    num_random: int = 64, num_envs: int = 4, env_steps: int = 16) -> str:
    """``runner.py --export onnx``: export, then print the path and the onnxruntime parity.

    Parity is measured on ``num_random`` observations drawn from the observation space and on the
    observations of ``env_steps`` policy steps in ``num_envs`` envs; a masked policy gets random
    masks with the former and the env's own masks with the latter. Returns the output path.
    """

    if not checkpoint:
        raise ConfigError("", "--checkpoint", "--export needs the checkpoint to export")
    _require("onnx")
    _require("onnxruntime")
    params = runner._require()
    output = output or default_output_path(checkpoint)
    model, env = _load(params, checkpoint, num_envs)
    try:
        space = env.observation_space
        graph_model, shape, dtype, take = exported_view(model, space)
        export_model_onnx(graph_model, shape, output, opset, dtype)
        session = onnx_session(output)
        seed = params.seed if params.seed is not None else 0
        random_diff = verify_onnx(graph_model, output, take(random_observations(space, num_random, seed)), session,
                                  seed=seed)
        real, real_masks = env_rollout(model, env, env_steps, seed)  # the env's observations, the model playing
        real_diff = verify_onnx(graph_model, output, take(real), session, masks=real_masks)
        rows = len(next(iter(real.values()))) if isinstance(real, dict) else len(real)
    finally:
        with contextlib.suppress(Exception):
            env.close()
    view = f" (input: obs_groups.{model.obs_group}, {shape[0]} features)" if graph_model is not model else ""
    print(f"exported ONNX policy to {output}{view}", flush=True)
    masked = " (with action masks)" if getattr(model, "use_action_masks", False) else ""
    print(f"onnxruntime parity{masked}: max abs diff {random_diff:.2e} on {num_random} random observations, "
          f"{real_diff:.2e} on {rows} env observations", flush=True)
    if max(random_diff, real_diff) > 1e-4:
        warnings.warn(f"ONNX output differs from PyTorch by {max(random_diff, real_diff):.2e}", stacklevel=2)
    return output
