"""Preallocated on-device rollout storage with flat and sequence (RNN) minibatch iterators.

Observations are one (T, N, *shape) buffer, or for a Dict observation space kept per key an
:class:`~rlchain.envs.obs_dict.ObsDict` of one buffer per key, each in its own dtype (uint8 images stay
uint8: a 3 x 84 x 84 frame takes 21 kB a step, not 85 kB).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import torch

from rlchain.envs.obs_dict import ObsDict, dict_zeros, is_dict_space, obs_row_bytes

ALL = slice(None)
"""Every env row: the default ``rows`` of :meth:`RolloutStorage.add` / ``add_outcome``."""


@dataclass
class Batch:
    """One minibatch, flat over (time, env): every per-step tensor has leading dim B.

    For an RNN the rows are ``B / seq_length`` sequences of ``seq_length`` consecutive steps,
    ``states`` are the RNN states entering each sequence (each (layers, B / seq_length, units))
    and ``resets`` (B,) marks steps whose observation starts a new episode.
    """

    obs: torch.Tensor | ObsDict
    actions: torch.Tensor
    log_probs: torch.Tensor
    values: torch.Tensor
    returns: torch.Tensor
    advantages: torch.Tensor
    params: torch.Tensor
    action_masks: torch.Tensor | None = None
    states: tuple[torch.Tensor, ...] | None = None
    resets: torch.Tensor | None = None
    seq_length: int = 1
    index: torch.Tensor | None = None
    """(B,) int64: each row's place in the rollout flattened time-major (t * num_envs + env)."""
    weights: torch.Tensor | None = None
    """(B,) float: each row's weight in the loss means (None: every row 1); a multi-agent policy's sequences
    weigh the steps its agents did not act at 0."""


def obs_buffer_layout(obs_space: Any) -> tuple[Any, torch.dtype]:
    """What :class:`RolloutStorage` takes for ``obs_space``: (the Dict space, float32) for a Dict kept per
    key (each key then keeps its own dtype), else (its shape, uint8 for a uint8 Box, float32 otherwise)."""
    if is_dict_space(obs_space):
        return obs_space, torch.float32
    return tuple(obs_space.shape), torch.uint8 if obs_space.dtype == "uint8" else torch.float32


def rollout_step_bytes(obs_space: Any, action_space: Any, value_size: int) -> int:
    """Bytes one step of one env row takes in :class:`RolloutStorage` (masks and RNN states left out): the
    estimate a run checks against free memory before the storage is built."""
    act = gym.spaces.flatdim(action_space)
    # the observation; actions, params; log prob; values .. returns; flags
    return obs_row_bytes(obs_space) + 4 * (3 * act + 1 + 5 * value_size) + 3


class RolloutStorage:
    """Fixed-size (T, N) buffers allocated once on the training device.

    ``add(t, ...)`` writes step t; writing past the horizon or reading an unfilled rollout raises.
    ``obs_shape`` is a shape (one buffer of ``obs_dtype``) or a gymnasium Dict space (one buffer per key,
    each in its space's dtype: an :class:`ObsDict`, see :func:`obs_buffer_layout`).
    ``mask_size`` > 0 keeps action masks; ``state_shapes`` (each (layers, N, units)) keeps the RNN
    states entering every step, for sequence minibatches.
    """

    def __init__(self, horizon: int, num_envs: int, obs_shape: tuple[int, ...] | gym.spaces.Dict,
                 obs_dtype: torch.dtype,
                 action_shape: tuple[int, ...], action_dtype: torch.dtype, param_size: int,
                 value_size: int, device: torch.device, mask_size: int = 0,
                 state_shapes: tuple[tuple[int, ...], ...] = ()) -> None:
        t, n = horizon, num_envs
        self.horizon, self.num_envs = horizon, num_envs
        kw = {"device": device}
        if isinstance(obs_shape, gym.spaces.Dict):
            self.obs: torch.Tensor | ObsDict = dict_zeros((t, n), obs_shape, device)
        else:
            self.obs = torch.zeros((t, n, *obs_shape), dtype=obs_dtype, **kw)
        self.actions = torch.zeros((t, n, *action_shape), dtype=action_dtype, **kw)
        self.log_probs = torch.zeros((t, n), **kw)
        self.values = torch.zeros((t, n, value_size), **kw)
        self.final_values = torch.zeros((t, n, value_size), **kw)
        self.params = torch.zeros((t, n, param_size), **kw)
        self.rewards = torch.zeros((t, n, value_size), **kw)
        self.terminated = torch.zeros((t, n), dtype=torch.bool, **kw)
        self.dones = torch.zeros((t, n), dtype=torch.bool, **kw)
        self.advantages = torch.zeros((t, n, value_size), **kw)
        self.returns = torch.zeros((t, n, value_size), **kw)
        self.action_masks = torch.zeros((t, n, mask_size), dtype=torch.bool, **kw) if mask_size else None
        self.states = tuple(torch.zeros((t, *shape), **kw) for shape in state_shapes)
        self.resets = torch.zeros((t, n), dtype=torch.bool, **kw) if state_shapes else None
        self.filled = 0

    def add(self, t: int, obs: torch.Tensor, actions: torch.Tensor, log_probs: torch.Tensor,
            values: torch.Tensor, params: torch.Tensor, action_masks: torch.Tensor | None = None,
            states: tuple[torch.Tensor, ...] = (), resets: torch.Tensor | None = None,
            rows: slice = ALL) -> None:
        """Record what the policy saw and did at step t (rewards/dones come with :meth:`add_outcome`).

        ``rows`` selects the envs the tensors are for (all of them by default; a pipelined rollout
        writes one env group at a time, see ``rlchain/envs/pipeline.py``); states are (layers, rows, H).
        """
        if not 0 <= t < self.horizon:
            raise IndexError(f"step {t} outside horizon {self.horizon}")
        at = t if rows is ALL and not isinstance(self.obs, dict) else (t, rows)  # every env: the step alone (cheaper)
        self.obs[at] = obs
        self.actions[at] = actions
        self.log_probs[at] = log_probs
        self.values[at] = values
        self.params[at] = params
        if self.action_masks is not None:
            self.action_masks[t, rows] = action_masks
        for buffer, state in zip(self.states, states):
            buffer[t, :, rows] = state
        if self.resets is not None:
            self.resets[t, rows] = resets
        self.filled = t + 1

    def written(self, steps: int) -> None:
        """The first ``steps`` steps were written in place, whole (APPO's learner batch from its fragments)."""
        self.filled = steps

    def add_outcome(self, t: int, rewards: torch.Tensor, terminated: torch.Tensor,
                    dones: torch.Tensor, rows: slice = ALL) -> None:
        """Record the env's answer to step t: shaped rewards (rows, V) and done flags (rows,)."""
        at = t if rows is ALL else (t, rows)  # every env: the step alone (cheaper)
        self.rewards[at] = rewards
        self.terminated[at] = terminated
        self.dones[at] = dones

    def _per_step(self, advantages: torch.Tensor) -> dict[str, torch.Tensor]:
        out = {"obs": self.obs, "actions": self.actions, "log_probs": self.log_probs, "values": self.values,
               "returns": self.returns, "advantages": advantages.reshape(self.horizon, self.num_envs),
               "params": self.params}
        if self.action_masks is not None:
            out["action_masks"] = self.action_masks
        return out

    def _check_filled(self) -> None:
        if self.filled != self.horizon:
            raise RuntimeError(f"rollout holds {self.filled} of {self.horizon} steps")

    def minibatches(self, minibatch_size: int, advantages: torch.Tensor, shuffle: bool = True) -> Iterator[Batch]:
        """Yield flat minibatches of the rollout; ``advantages`` is (T, N) or (T*N,).

        ``shuffle``: a fresh permutation of all T * N steps. Otherwise the fixed env-major order
        (:func:`env_major_order`): minibatch k is the same block of whole env trajectories every
        time it is asked for. ``Batch.index`` is each row's time-major flat index ``t * N + n``.
        """
        self._check_filled()
        size = self.horizon * self.num_envs
        flat = {k: v.reshape(size, *v.shape[2:]) for k, v in self._per_step(advantages).items()}
        if shuffle:
            order = torch.randperm(size, device=self.obs.device)
        else:
            order = env_major_order(self.horizon, self.num_envs, self.obs.device)
        packed = pack_rows(flat) if shuffle and self.obs.device.type == "cpu" and minibatch_size >= PACKED_MIN_ROWS \
            else None
        whole = packed is None and sum(_nbytes(v) for v in flat.values()) <= PASS_GATHER_BYTES
        if whole:  # the pass's rows gathered in its order at once: each minibatch is a slice of them
            flat = {k: v.index_select(0, order) for k, v in flat.items()}
        for start in range(0, size, minibatch_size):
            idx = order[start:start + minibatch_size]
            if whole:
                yield Batch(**{k: v[start:start + minibatch_size] for k, v in flat.items()}, index=idx)
            elif packed is None:
                yield Batch(**{k: v.index_select(0, idx) for k, v in flat.items()}, index=idx)
            else:  # one gather of whole rows instead of one per field
                rows, layout = packed
                yield Batch(**unpack_rows(rows.index_select(0, idx), layout), index=idx)

    def rows_batch(self, index: torch.Tensor, advantages: torch.Tensor) -> Batch:
        """One minibatch of the given rows (``index``: time-major flat indices ``t * N + n``, in any order,
        repeats allowed); ``advantages`` is (T, N) or (T*N,). For an order the caller chose (RLlib's cyclic
        minibatches, rlchain.algos.ppo.rllib_batch)."""
        self._check_filled()
        size = self.horizon * self.num_envs
        flat = {k: v.reshape(size, *v.shape[2:]) for k, v in self._per_step(advantages).items()}
        return Batch(**{k: v.index_select(0, index) for k, v in flat.items()}, index=index)

    def sequence_minibatches(self, minibatch_size: int, seq_length: int, advantages: torch.Tensor,
                             use_resets: bool = True, shuffle: bool = True) -> Iterator[Batch]:
        """Yield minibatches of whole sequences: ``seq_length`` consecutive steps of one env each.

        The horizon is cut into T / seq_length chunks per env; sequences are shuffled (or, without
        ``shuffle``, in the fixed env-major order: env 0's chunks in time order, then env 1's), never
        their steps. Each batch carries the stored RNN states entering its sequences and, with
        ``use_resets``, the episode starts inside them.
        """
        self._check_filled()
        t, n, length = self.horizon, self.num_envs, seq_length
        if t % length or minibatch_size % length:
            raise ValueError(f"horizon {t} and minibatch {minibatch_size} must divide by seq_length {length}")
        chunks = t // length
        count = chunks * n  # sequences

        def by_sequence(x: torch.Tensor) -> torch.Tensor:  # (T, N, ...) -> (S * L, ...), sequence-major
            return x.reshape(chunks, length, n, *x.shape[2:]).transpose(1, 2).reshape(count * length, *x.shape[2:])

        flat = {k: by_sequence(v) for k, v in self._per_step(advantages).items()}
        flat["index"] = by_sequence(torch.arange(t * n, device=self.obs.device).reshape(t, n))
        if use_resets and self.resets is not None:
            flat["resets"] = by_sequence(self.resets)
        # states entering each sequence: (chunks, layers, N, units) -> (layers, S, units)
        starts = [s[::length].permute(1, 0, 2, 3).reshape(s.shape[1], count, s.shape[-1]) for s in self.states]
        per_batch = minibatch_size // length
        device = self.obs.device
        order = torch.randperm(count, device=device) if shuffle else env_major_order(chunks, n, device)
        steps = torch.arange(length, device=self.obs.device)
        for start in range(0, count, per_batch):
            seqs = order[start:start + per_batch]
            rows = (seqs.unsqueeze(1) * length + steps).reshape(-1)
            batch = {k: v.index_select(0, rows) for k, v in flat.items()}
            yield Batch(**batch, states=tuple(s.index_select(1, seqs) for s in starts), seq_length=length)


PACKED_ROW_WORDS = 64
"""Rows up to this many 4-byte words wide are gathered as one packed row in shuffled CPU minibatches."""

PACKED_MIN_ROWS = 2048
"""Minibatches smaller than this gather field by field: their rollout stays in cache, and packing and
unpacking cost more than the gathers they save (gymnasium CartPole, 64 envs, minibatch 256: 0.94x)."""

PASS_GATHER_BYTES = 16 << 20
"""Rollouts up to this size are gathered once per pass, field by field in the pass's order, and each minibatch
is a slice of that copy (the same rows: one gather per field and pass instead of one per field and minibatch,
which is most of a small minibatch's gathering cost). A larger rollout gathers minibatch by minibatch, so it
is never held twice."""


def _nbytes(value: torch.Tensor | ObsDict) -> int:
    if isinstance(value, ObsDict):
        return sum(v.nbytes for v in value.values())
    return value.nbytes


_WORDS = {torch.float32: 1, torch.int64: 2, torch.bool: 1}  # how each dtype travels in a packed row


def pack_rows(flat: dict[str, torch.Tensor]) -> tuple[torch.Tensor, list[tuple]] | None:
    """The (size, ...) per-step fields side by side in one (size, W) float32 tensor, and where each lies.

    A shuffled minibatch gathers random rows of every field; on a CPU each field's gather waits on a
    cache miss per row (62 us for 8,192 rows of a 4-float field after an update has evicted them, 7
    fields per minibatch), so one gather of whole packed rows costs about one field's. float32 fields
    go in as they are, int64 ones as their bytes (two float32 words, never converted: any value comes
    back exactly), bool ones as 0/1. None where a field has another dtype or the row is wider than
    :data:`PACKED_ROW_WORDS` (an image is gathered field by field: its rows fill cache lines anyway).
    """
    if any(isinstance(v, ObsDict) or v.dtype not in _WORDS for v in flat.values()):
        return None
    cols = [v.reshape(v.shape[0], -1) for v in flat.values()]
    if sum(c.shape[1] * _WORDS[c.dtype] for c in cols) > PACKED_ROW_WORDS:
        return None
    layout, parts, at = [], [], 0
    for (key, value), col in zip(flat.items(), cols):
        part = col.float() if col.dtype == torch.bool else col.contiguous().view(torch.float32)
        layout.append((key, at, at + part.shape[1], value.shape[1:], value.dtype))
        parts.append(part)
        at += part.shape[1]
    return torch.cat(parts, 1), layout


def unpack_rows(rows: torch.Tensor, layout: list[tuple]) -> dict[str, torch.Tensor]:
    """The fields of gathered packed ``rows`` (B, W), each back in its dtype and per-row shape."""
    out = {}
    for key, start, stop, shape, dtype in layout:
        part = rows[:, start:stop].contiguous()
        part = part.bool() if dtype == torch.bool else part.view(dtype)
        out[key] = part.reshape(rows.shape[0], *shape)
    return out


def env_major_order(horizon: int, num_envs: int, device: torch.device | str = "cpu") -> torch.Tensor:
    """The (T * N,) time-major flat indices ``t * N + n`` listed env by env: env 0's T steps, then env 1's.

    Cut into minibatches of size B, each holds B / T whole env trajectories (rl_games' order: it
    flattens the rollout env-major and never shuffles). Example T=2, N=3: [0, 3, 1, 4, 2, 5].
    """
    return torch.arange(horizon * num_envs, device=device).reshape(horizon, num_envs).t().reshape(-1)

