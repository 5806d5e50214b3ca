"""The PPO minibatch step, run one of three ways: eagerly, with the losses compiled (``compile_update``), or
as a captured CUDA graph (``cuda_graph``). Each does losses, backward, gradient clipping and the optimizer
step, and returns the same statistics."""

from __future__ import annotations

import time
from collections.abc import Callable

import torch

from rlchain.algos.core.storage import Batch
from rlchain.algos.ppo.graph_step import GraphedStep, zero_non_finite_
from rlchain.algos.ppo.loss import LossOutput, named_stats, stats_vector
from rlchain.algos.ppo.optimizer import ScheduledAdam
from rlchain.errors import DivergenceError, first_non_finite
from rlchain.log import get_logger
from rlchain.parallel.communicator import SINGLE, Communicator

_log = get_logger(__name__)

LossFn = Callable[[Batch, torch.Tensor, torch.Tensor], LossOutput]
"""(batch, entropy coefficient (0-d), KL reference (B, P)) -> :data:`rlchain.algos.ppo.loss.LossOutput`."""


class MinibatchStep:
    """One minibatch update through ``losses`` and ``adam``: :attr:`mode` says which way it runs.

    eager: the losses, backward, gradient averaging over ranks, unscaling (float16), clipping and Adam, with
    one host sync to read the statistics; a non-finite statistic raises DivergenceError before the step
    (with a grad scaler the scaler skips inf steps itself). compiled: the same with the losses as one
    compiled region (:meth:`compile`). graphed: :meth:`sync_free_step` recorded once as a CUDA graph
    (:class:`rlchain.algos.ppo.graph_step.GraphedStep`) and replayed; a non-finite step leaves the
    parameters as they were and raises after the replay.
    """

    def __init__(self, losses: LossFn, adam: ScheduledAdam, comm: Communicator = SINGLE,
                 graphed: bool = False) -> None:
        self.losses = losses
        self.adam = adam
        self.params = adam.params
        self.comm = comm  # multi_gpu: gradients are averaged over ranks before clipping
        self.losses_fn = losses  # compile() swaps in the compiled region
        self._compile_pending = False
        self.graphed = GraphedStep(self.sync_free_step, adam.zero_grad) if graphed else None
        self._aux_names: tuple[str, ...] = ()
        self._max_norm = float("inf")

    @property
    def mode(self) -> str:
        """``graphed``, ``compiled`` or ``eager``."""
        if self.graphed is not None:
            return "graphed"
        return "compiled" if self.losses_fn is not self.losses else "eager"

    def compile(self) -> None:
        """``compile_update``: from now on the losses run as one compiled region with static shapes (the
        minibatch size divides the batch, so every minibatch has the same shape). The compile happens on
        the first minibatch; its seconds are logged."""
        self.losses_fn = torch.compile(self.losses, dynamic=False)
        self._compile_pending = True

    def reset(self) -> None:
        """The optimizer's state tensors or a value the step holds as a constant changed: a captured step
        is recorded again."""
        if self.graphed is not None:
            self.graphed.reset()

    def __call__(self, batch: Batch, coef: torch.Tensor, previous: torch.Tensor, reference: torch.Tensor | None,
                 max_norm: float) -> dict[str, float]:
        """One minibatch step with entropy coefficient ``coef`` (0-d) and the KL measured against ``previous``
        (B, P); gradients clipped to ``max_norm`` (inf: not clipped). With ``reference`` (the whole rollout's
        (T * N, P) KL reference) the rows of this batch are overwritten with the policy this step saw.
        Returns the step's statistics by name (:data:`rlchain.algos.ppo.loss.STEP_STATS` but ``loss``, then
        ``losses/<name>``)."""
        self._max_norm = max_norm
        if self.graphed is not None:
            return self._graph_step(batch, coef, previous, reference)
        loss, stats_t, aux, current = self._losses(batch, coef, previous)
        if reference is not None:  # the next pass measures the KL against the policy this one saw
            reference.index_copy_(0, batch.index, current)
        adam = self.adam
        adam.zero_grad()
        adam.backward(loss)
        if self.comm.active:  # before unscaling and clipping, so every rank sees the same grads
            self.comm.average_gradients(self.params)
        adam.unscale()
        stats = named_stats(stats_vector(loss, stats_t, aux, self._clip_grads()).tolist(), aux)
        bad = first_non_finite(stats)
        if bad is not None and adam.scaler is None:  # with AMP the scaler skips inf steps itself
            raise DivergenceError(f"{bad} in the PPO update")
        adam.step()
        del stats["loss"]
        return stats

    def _losses(self, batch: Batch, coef: torch.Tensor, previous: torch.Tensor) -> LossOutput:
        """The losses through ``losses_fn``, logging the seconds the first (compiling) call took."""
        if not self._compile_pending:
            return self.losses_fn(batch, coef, previous)
        start = time.perf_counter()
        out = self.losses_fn(batch, coef, previous)
        self._compile_pending = False
        _log.info(f"compile_update: compiled the PPO minibatch step in {time.perf_counter() - start:.1f} s")
        return out

    def sync_free_step(self, batch: Batch, coef: torch.Tensor, previous: torch.Tensor
                       ) -> tuple[torch.Tensor, torch.Tensor]:
        """The minibatch step ``cuda_graph`` captures: losses, backward, clip, Adam, with no host sync.

        Returns (the statistics of :data:`rlchain.algos.ppo.loss.STEP_STATS` then the auxiliary losses, as one
        float32 vector; the policy's params). The gradients must be None or zero on entry (the eager warm-up
        sets them to None; in the graph backward writes the graph's own). A non-finite statistic zeroes the
        gradients and this step's lr, so the parameters stay as they were and the caller raises on the
        statistics.
        """
        loss, stats_t, aux, current = self._losses(batch, coef, previous)
        loss.backward()
        values = stats_vector(loss, stats_t, aux, self._clip_grads())
        finite = torch.isfinite(values).all()
        zero_non_finite_(finite, self.params)
        self.adam.lr_step.copy_(self.adam.lr_live * finite)
        self.adam.optimizer.step()
        self._aux_names = tuple(aux)
        return values, current

    def _graph_step(self, batch: Batch, coef: torch.Tensor, previous: torch.Tensor,
                    reference: torch.Tensor | None) -> dict[str, float]:
        """The step through the captured graph: the same statistics, one host sync to read them."""
        values, current = self.graphed(batch, coef, previous)
        if reference is not None:
            reference.index_copy_(0, batch.index, current)
        stats = named_stats(values.tolist(), self._aux_names)
        bad = first_non_finite(stats)
        if bad is not None:  # the step left the parameters as they were
            raise DivergenceError(f"{bad} in the PPO update")
        del stats["loss"]
        return stats

    def _clip_grads(self) -> torch.Tensor:
        """Clip the gradients to the call's ``max_norm``; their total norm before clipping."""
        return torch.nn.utils.clip_grad_norm_(self.params, self._max_norm, foreach=True)
