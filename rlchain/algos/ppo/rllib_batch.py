"""RLlib's PPO train batch over rlchain's rollout: its rows, its advantage standardization, its minibatch order.

RLlib's learner does not train on the rollout's steps alone. Its ``AddOneTsToEpisodesAndTruncate`` connector
appends one masked row after every episode chunk (the chunk's final observation, reward 0, neither terminated nor
truncated), so the value function can bootstrap from it; the batch is the chunks one after the other (one env
runner's episodes in time order, then the next runner's), each followed by its extra row. Two things follow
from those rows, and ``minibatch_order: rllib`` / ``advantage_normalization: rllib`` reproduce them:

- **standardization**: ``GeneralAdvantageEstimation`` runs GAE over the whole concatenated batch and
  standardizes the advantages over every row, the extra ones too (``(a - mean) / max(1e-4, std)``, numpy's
  population std). An extra row's advantage is ``gamma * V(next chunk's first obs) - V(final obs) + gamma *
  lambda * A(next chunk's first step)`` (its ``propagate`` flag is 1, its reward 0), ``-V(final obs)`` for the
  batch's last row. :func:`bootstrap_advantages` computes them, :func:`rllib_standardized` standardizes.
- **minibatch order**: ``MiniBatchCyclicIterator`` takes ``minibatch_size`` consecutive rows of the batch (extra
  rows included: the loss is the mean over a minibatch's real rows, ``possibly_masked_mean``), the first pass in
  the stored order; when a minibatch runs past the end it wraps, the batch is shuffled and one more pass is
  counted; it stops once every row was covered ``num_epochs`` times. :func:`batch_rows` lays out the rows,
  :func:`cyclic_minibatches` cuts them.

The rows here are in rlchain's (T, N) rollout, chunk order env by env: RLlib's order with one env per env runner
(the face's ``num_envs_per_env_runner`` 1); a runner with several envs hands RLlib its finished episodes in the
order they ended, then its unfinished chunks, which this order does not follow.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import torch

BOOTSTRAP = -1
"""The row index :func:`batch_rows` gives RLlib's masked extra rows."""


def batch_rows(dones: np.ndarray) -> np.ndarray:
    """RLlib's train batch rows for a rollout with (T, N) ``dones``: env 0's steps in time order with a
    :data:`BOOTSTRAP` row after each of its episode chunks (after every done step, and after its last step
    when that ended no episode), then env 1's, ... Real rows are the time-major flat index ``t * N + n``.

    Example T=3, N=2, env 0 done at t=0: [0, -1, 2, 4, -1, 1, 3, 5, -1].
    """
    dones = np.asarray(dones, bool)
    horizon, envs = dones.shape
    rows = []
    for n in range(envs):
        ends = dones[:, n].copy()
        ends[-1] = True  # the last step closes a chunk either way
        flat = np.arange(horizon) * envs + n
        column = np.full(horizon + int(ends.sum()), BOOTSTRAP, np.int64)
        column[np.arange(horizon) + np.concatenate(([0], np.cumsum(ends)[:-1]))] = flat
        rows.append(column)
    return np.concatenate(rows)


def bootstrap_advantages(rows: np.ndarray, dones: np.ndarray, values: np.ndarray, final_values: np.ndarray,
                         last_values: np.ndarray, advantages: np.ndarray, gamma: float, lam: float) -> np.ndarray:
    """The raw advantages RLlib's GAE gives the extra rows of ``rows`` (:func:`batch_rows` of ``dones``), in
    their order.

    ``dones``, ``values``, ``final_values`` (V of the final observation where an episode ended at that step),
    ``advantages`` (the real rows' raw GAE advantages): (T, N); ``last_values`` (N,): V of each env's
    observation after the rollout. The extra row after a chunk ending at (t, n) holds V(final obs)
    (``final_values[t, n]`` where an episode ended, else ``last_values[n]``); the real row after it (the next
    chunk's first step; none after the batch's last row) gives its bootstrap, ``gamma * (V(s) + lam * A(s))``.
    """
    envs = values.shape[1]
    flat_values, flat_adv = values.reshape(-1), advantages.reshape(-1)
    at = np.flatnonzero(rows == BOOTSTRAP)
    ends = rows[at - 1]  # the last real row of each chunk (a chunk has at least one step)
    t, n = ends // envs, ends % envs
    own = np.where(np.asarray(dones, bool)[t, n], final_values[t, n], last_values.reshape(-1)[n])
    following = np.append(rows[at[:-1] + 1], BOOTSTRAP) if len(at) else at
    has_next = following != BOOTSTRAP
    nxt = np.where(has_next, following, 0)
    boot = np.where(has_next, gamma * (flat_values[nxt] + lam * flat_adv[nxt]), 0.0)
    return (boot - own).astype(np.float32)


def rllib_standardized(advantages: torch.Tensor, extra: np.ndarray) -> torch.Tensor:
    """``advantages`` (any shape) standardized as RLlib's GAE connector does over its batch: the mean and the
    population std taken over them and the ``extra`` rows' advantages together, the std at least 1e-4."""
    flat = advantages.reshape(-1).double()
    both = torch.cat([flat, torch.as_tensor(extra, dtype=torch.float64, device=flat.device)])
    mean, std = both.mean(), both.std(unbiased=False)
    return ((advantages.double() - mean) / torch.clamp(std, min=1e-4)).to(advantages.dtype)


def torch_permutation(size: int) -> np.ndarray:
    """A permutation of ``size`` rows from torch's global generator (the run's seed)."""
    return torch.randperm(size).numpy()


def cyclic_minibatches(size: int, minibatch_size: int, num_epochs: int,
                       permutation: Callable[[int], np.ndarray] | None = None) -> list[list[np.ndarray]]:
    """RLlib's ``MiniBatchCyclicIterator`` over ``size`` rows: each minibatch's positions in the batch as RLlib
    takes them, grouped by the pass each minibatch starts in (``num_epochs`` groups; a group can be empty when a
    minibatch is larger than the batch).

    The first pass is the stored order; a minibatch that reaches the end of the batch takes the rest, counts a
    pass, shuffles the batch (``permutation(size)``: the new order of the shuffled batch's rows) and goes on from
    its start. The iterator stops once ``num_epochs`` passes are counted: ``ceil(num_epochs * size /
    minibatch_size)`` minibatches. ``permutation`` defaults to this module's :func:`torch_permutation` (looked up
    at the call: benchmarks/peers/rllib_same_batch.py replays RLlib's own permutations through it).
    """
    permutation = permutation or torch_permutation
    order = np.arange(size)
    start, covered = 0, 0
    groups: list[list[np.ndarray]] = [[] for _ in range(num_epochs)]
    while covered < num_epochs:
        group, need, parts = covered, minibatch_size, []
        while start + need >= size:
            parts.append(order[start:])
            need -= size - start
            start = 0
            covered += 1
            order = order[np.asarray(permutation(size))]
        if need > 0:
            parts.append(order[start:start + need])
            start += need
        groups[group].append(np.concatenate(parts))
    return groups


def rllib_bootstrap_advantages(storage: Any, last_values: torch.Tensor, gamma: float, lam: float) -> np.ndarray:
    """:func:`bootstrap_advantages` of a filled rollout storage (after GAE; ``final_values`` still holding V(final
    obs) at every done step) and the values of the observations after it; value heads summed."""
    as_np = lambda x: x.detach().float().cpu().numpy()
    dones = as_np(storage.dones).astype(bool)
    return bootstrap_advantages(batch_rows(dones), dones, as_np(storage.values.sum(-1)),
                                as_np(storage.final_values.sum(-1)), as_np(last_values.reshape(dones.shape[1], -1)
                                                                           .sum(-1)),
                                as_np(storage.advantages.sum(-1)), gamma, lam)
