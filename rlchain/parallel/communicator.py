"""How an algorithm and its normalizers talk to the other processes of a run.

A :class:`Communicator` is handed to whatever needs the other ranks when it is built: the Loop
and its agents take it as an argument, the normalizers inside a model read the one in force while
the model is built (:func:`building_with`), so user model builders need no new parameter. The base
class is a single process, where every collective is the identity; ``parallel.distributed.Distributed``
is the torch.distributed one (torchrun, ``multi_gpu: True``).
"""

from __future__ import annotations

import contextvars
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import torch


def merge_moments(means: torch.Tensor, variances: torch.Tensor, counts: torch.Tensor
                  ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Mean, (population) variance and count of the union of R batches.

    means, variances: (R, *shape); counts: (R,). Exact (parallel-variance formula), in the input dtype.
    """
    shape = (-1,) + (1,) * (means.dim() - 1)
    weights = counts.reshape(shape)
    total = counts.sum()
    mean = (weights * means).sum(0) / total
    var = (weights * (variances + (means - mean).square())).sum(0) / total
    return mean, var, total


class Communicator:
    """One process alone: averaging, merging and broadcasting change nothing.

    ``rank`` and ``world_size`` are instance attributes (a subclass may declare them as dataclass fields).
    """

    def __init__(self) -> None:
        self.rank = 0
        self.world_size = 1

    @property
    def is_main(self) -> bool:
        """Rank 0 writes the run folder, logs and checkpoints."""
        return self.rank == 0

    @property
    def active(self) -> bool:
        """Whether there are other processes to talk to."""
        return self.world_size > 1

    def average_gradients(self, params: list[torch.Tensor]) -> None:
        """Average the gradients of ``params`` over the ranks (in place)."""

    def combine_moments(self, mean: torch.Tensor, var: torch.Tensor, count: float
                        ) -> tuple[torch.Tensor, torch.Tensor, float]:
        """The moments of every rank's batch, combined."""
        return mean, var, count

    def mean(self, value: float) -> float:
        """A scalar averaged over the ranks."""
        return value

    def episode_stats(self, tracker: Any) -> dict[str, float] | None:
        """Mean reward and length of the tracked finished games, and their ``success`` rate when the env
        reports success (None when no game finished)."""
        if not tracker.has_data:
            return None
        stats = {"reward": tracker.mean_return(), "length": tracker.mean_length()}
        if tracker.has_success:
            stats["success"] = tracker.success_rate()
        return stats

    def broadcast_learner(self, model: torch.nn.Module, agent: Any) -> None:
        """Give every rank rank 0's parameters, buffers and agent state (optimizer, lr)."""

    def gather_objects(self, obj: Any) -> list[Any]:
        """Every rank's ``obj`` (picklable), in rank order, on every rank (exact resume: each rank's
        envs and random streams go into rank 0's checkpoints)."""
        return [obj]


SINGLE = Communicator()
"""The communicator of an ordinary single-process run."""

_current: contextvars.ContextVar[Communicator] = contextvars.ContextVar("rlchain_communicator", default=SINGLE)


def current() -> Communicator:
    """The communicator in force: what a normalizer built now syncs through."""
    return _current.get()


@contextmanager
def building_with(comm: Communicator) -> Iterator[Communicator]:
    """Build models (and their normalizers) inside this block to hand them ``comm``."""
    token = _current.set(comm)
    try:
        yield comm
    finally:
        _current.reset(token)
