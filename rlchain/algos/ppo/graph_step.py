"""``cuda_graph``: the PPO minibatch step and the rollout's act step, each captured once as a CUDA graph
and replayed.

An eager minibatch step of a small policy is some hundreds of kernel launches (forward, losses, backward,
clipping, Adam) that cost ~4 ms of host time for ~0.1 ms of GPU work (docs/benchmarks.md, "On a GPU").
After a few eager warm-up steps (real updates: they initialise the optimizer state and the autograd
and cuBLAS workspaces, on a side stream as torch.cuda.graphs asks) the step is recorded once into
static buffers and then replayed: per minibatch the host copies the batch into those buffers, launches
one graph and reads back the step's statistics.

What the step does is :meth:`PPOAgent.sync_free_step`, the same losses as the eager step but without
host syncs: a non-finite loss or gradient does not raise inside the graph, it zeroes the gradients and
the learning rate for that step (the parameters stay as they were) and the statistics read back after
the replay raise the DivergenceError there. Anything that replaces the optimizer's state tensors (a
checkpoint load, a divergence rollback) makes the agent call :meth:`GraphedStep.reset`, and the step is
captured again.

:class:`GraphedAct` does the same for the rollout's act step of a feed-forward policy over every env
(normalise, forward, sample, log-prob, values): a few dozen launches become one. The parameters and
normaliser statistics it reads are updated in place, so the graph stays valid for the whole run.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields

import torch

from rlchain.algos.core.storage import Batch
from rlchain.log import get_logger

_log = get_logger(__name__)

StepFn = Callable[[Batch, torch.Tensor, torch.Tensor], tuple[torch.Tensor, torch.Tensor]]
"""(batch, entropy coefficient (0-d), KL reference (B, P)) -> (step statistics (K,), the policy's params (B, P))."""

WARMUP_STEPS = 3
"""Eager steps before the capture (torch.cuda.graphs' whole-network example warms up with 3)."""

_BATCH_TENSORS = tuple(f.name for f in fields(Batch) if f.name not in ("states", "resets", "seq_length", "index"))


class GraphedStep:
    """Runs ``step_fn`` on static copies of each minibatch: eagerly for the first ``warmup`` calls, then as
    one captured CUDA graph. ``before_capture`` runs just before recording (the agent sets its gradients
    to None there, so backward allocates them in the graph's memory pool)."""

    def __init__(self, step_fn: StepFn, before_capture: Callable[[], None], warmup: int = WARMUP_STEPS) -> None:
        self.step_fn = step_fn
        self.before_capture = before_capture
        self.warmup = warmup
        self.captures = 0  # how often the step was recorded (1 in a run without rollbacks or loads)
        self.reset()

    def reset(self) -> None:
        """Forget the graph and its buffers: the next calls warm up and capture again."""
        self.graph: torch.cuda.CUDAGraph | None = None
        self._inputs: dict[str, torch.Tensor] | None = None
        self._outputs: tuple[torch.Tensor, torch.Tensor] | None = None
        self._warmup_left = self.warmup

    def __call__(self, batch: Batch, coef: torch.Tensor, reference: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """One minibatch step; returns (statistics, the policy's params), both owned by the graph after the
        capture: read or copy them before the next call."""
        inputs = self._load(batch, coef, reference)
        if self.graph is not None:
            self.graph.replay()
            return self._outputs
        static = _static_batch(inputs)
        if self._warmup_left > 0:
            self._warmup_left -= 1
            if not inputs["coef"].is_cuda:  # no graphs off CUDA: eager on the static buffers (unit tests)
                return self.step_fn(static, inputs["coef"], inputs["reference"])
            side = torch.cuda.Stream()
            side.wait_stream(torch.cuda.current_stream())
            with torch.cuda.stream(side):
                out = self.step_fn(static, inputs["coef"], inputs["reference"])
            torch.cuda.current_stream().wait_stream(side)
            return out
        self.before_capture()
        graph = torch.cuda.CUDAGraph()
        with torch.cuda.graph(graph):
            self._outputs = self.step_fn(static, inputs["coef"], inputs["reference"])
        self.graph = graph
        self.captures += 1
        _log.info(f"cuda_graph: captured the PPO minibatch step (capture {self.captures})")
        graph.replay()  # recording ran nothing: this is the step
        return self._outputs

    def _load(self, batch: Batch, coef: torch.Tensor, reference: torch.Tensor) -> dict[str, torch.Tensor]:
        """Copy the minibatch into the static input buffers (allocated like the first batch)."""
        given = {name: getattr(batch, name) for name in _BATCH_TENSORS if getattr(batch, name) is not None}
        given["coef"], given["reference"] = coef, reference
        if self._inputs is None:
            self._inputs = {name: torch.empty_like(value) for name, value in given.items()}
        for name, value in given.items():
            self._inputs[name].copy_(value)
        return self._inputs


def _static_batch(inputs: dict[str, torch.Tensor]) -> Batch:
    return Batch(**{name: inputs[name] for name in _BATCH_TENSORS if name in inputs})


def zero_non_finite_(finite: torch.Tensor, params: list[torch.nn.Parameter]) -> None:
    """Zero every gradient unless ``finite`` (a 0-d bool): a step with a NaN or inf loss leaves Adam's
    moments finite (no host sync, so it can run inside a graph)."""
    for param in params:
        if param.grad is not None:
            param.grad.copy_(torch.where(finite, param.grad, torch.zeros_like(param.grad)))


class GraphedAct:
    """``act_fn(obs)`` (the model's act step) eagerly for the first ``warmup`` calls, then as one captured
    CUDA graph on a static copy of ``obs``. The returned dict holds the graph's buffers (overwritten by the
    next call) except the actions, which are a copy the env may keep."""

    def __init__(self, act_fn: Callable[[torch.Tensor], dict], warmup: int = WARMUP_STEPS) -> None:
        self.act_fn = act_fn
        self.warmup = warmup
        self.graph: torch.cuda.CUDAGraph | None = None
        self._obs: torch.Tensor | None = None
        self._outputs: dict | None = None
        self._warmup_left = warmup

    def __call__(self, obs: torch.Tensor) -> dict:
        if self._obs is None or self._obs.shape != obs.shape or self._obs.dtype != obs.dtype:
            self.graph, self._obs, self._warmup_left = None, torch.empty_like(obs), self.warmup
        self._obs.copy_(obs)
        if not obs.is_cuda:  # no graphs off CUDA: eager on the static buffer (unit tests)
            return self.act_fn(self._obs)
        if self.graph is None and self._warmup_left > 0:
            self._warmup_left -= 1
            side = torch.cuda.Stream()
            side.wait_stream(torch.cuda.current_stream())
            with torch.cuda.stream(side):
                out = self.act_fn(self._obs)
            torch.cuda.current_stream().wait_stream(side)
            return out
        if self.graph is None:
            graph = torch.cuda.CUDAGraph()
            with torch.cuda.graph(graph):
                self._outputs = self.act_fn(self._obs)
            self.graph = graph
            _log.info("cuda_graph: captured the rollout's act step")
        self.graph.replay()
        return {**self._outputs, "actions": self._outputs["actions"].clone()}
