"""``cuda_graph``: the PPO minibatch step and the rollout's act step, each captured once as a CUDA graph
and replayed.

An eager minibatch step of a small policy is some hundreds of kernel launches (forward, losses, backward,
clipping, Adam) that cost ~4 ms of host time for ~0.1 ms of GPU work (docs/benchmarks.md, "On a GPU").
After a few eager warm-up steps (real updates: they initialise the optimizer state and the autograd
and cuBLAS workspaces, on a side stream as torch.cuda.graphs asks) the step is recorded once into
static buffers and then replayed: per minibatch the host copies the batch into those buffers, launches
one graph and reads back the step's statistics.

What the step does is :meth:`rlchain.algos.ppo.agent.PPOAgent._sync_free_step`, the same losses as the
eager step but without host syncs: a non-finite loss or gradient does not raise inside the graph, it zeroes
the gradients and the learning rate for that step (the parameters stay as they were) and the statistics read
back after the replay raise the DivergenceError there. Anything that replaces the optimizer's state tensors (a
checkpoint load, a divergence rollback) makes the agent call :meth:`GraphedStep.reset`, and the step is
captured again.

:class:`GraphedAct` does the same for the rollout's act step of a feed-forward policy over every env
(normalise, forward, sample, log-prob, values): a few dozen launches become one. The parameters and
normaliser statistics it reads are updated in place, so the graph stays valid for the whole run.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields
from typing import Any

import torch

from rlchain.algos.core.precision import autocast_dtype
from rlchain.algos.core.storage import Batch
from rlchain.config.compile import parse_compile
from rlchain.config.errors import ConfigError
from rlchain.log import get_logger

_log = get_logger(__name__)

KEY = "params.config.cuda_graph"
GRAPHING_COMPILE_MODES = ("reduce-overhead", "max-autotune")
"""torch.compile modes that record CUDA graphs of their own (a graph cannot be captured inside another)."""


def resolve_cuda_graph(cfg: Any, network: torch.nn.Module, is_rnn: bool, device: torch.device, distributed: bool,
                       source: str) -> bool:
    """Whether PPO captures its steps as CUDA graphs, from ``cuda_graph`` (True, False, auto).

    The graphs need a CUDA device, a feed-forward network without ``get_aux_loss()``, no float16 grad
    scaler, one process and no torch.compile mode that records graphs itself. ``auto`` (the default) turns
    them on where all of that holds, the network is one of rlchain's own (a user's network might sync with
    the host inside its forward pass, which a graph cannot hold) and none of ``torch_compile``,
    ``compile_update`` and ``mixed_precision`` is set (measured without them), and logs why not on a GPU
    where it does not. ``True``
    where they cannot run is a one-line ConfigError (on a CPU a warning: a GPU config run on a CPU).
    """
    value = cfg.cuda_graph
    if value is False:
        return False
    explicit = value is True
    on_cuda = device.type == "cuda"
    if not on_cuda and not explicit:
        return False
    compile_spec = parse_compile(cfg.torch_compile)
    blockers = [  # what True cannot do on any device (a ConfigError on a CPU too, where the config is tried)
        (is_rnn, "False for an RNN network (sequence minibatches are not captured); set it false"),
        (callable(getattr(network, "get_aux_loss", None)),
         "False for a network with get_aux_loss() (its losses are checked in Python)"),
        (cfg.mixed_precision == "fp16" or (on_cuda and autocast_dtype(cfg.mixed_precision, device) == torch.float16),
         "False with float16 mixed precision (its grad scaler syncs with the host); use mixed_precision: bf16 "
         "or set cuda_graph false"),
        (distributed, "False with multi_gpu (the gradients are averaged between ranks outside the graph); set it "
                      "false"),
        (compile_spec is not None and compile_spec.mode in GRAPHING_COMPILE_MODES,
         "False with torch_compile mode reduce-overhead or max-autotune (they record CUDA graphs themselves)"),
    ]
    if not explicit:
        blockers += [
            (compile_spec is not None or cfg.compile_update or cfg.mixed_precision is not False,
             "auto is off with torch_compile, compile_update or mixed_precision (not measured together); set "
             "cuda_graph: True"),
            (not type(network).__module__.startswith("rlchain."),
             f"auto is off for a network of your own ({type(network).__name__}); set cuda_graph: True once its "
             f"forward pass has no host syncs"),
        ]
    for blocked, why in blockers:
        if blocked and explicit:
            raise ConfigError(source, KEY, why)
        if blocked:
            _log.info(f"cuda_graph: eager steps ({why.removeprefix('False ').split(';')[0]})")
            return False
    if not on_cuda:
        _log.warning(f"cuda_graph: True needs a CUDA device; the PPO update runs eagerly on {device}")
        return False
    return True


StepFn = Callable[[Batch, torch.Tensor, torch.Tensor], tuple[torch.Tensor, torch.Tensor]]
"""(batch, entropy coefficient (0-d), KL reference (B, P)) -> (step statistics (K,), the policy's params (B, P))."""

WARMUP_STEPS = 3
"""Eager steps before the capture (torch.cuda.graphs' whole-network example warms up with 3)."""

_BATCH_TENSORS = tuple(f.name for f in fields(Batch) if f.name not in ("states", "resets", "seq_length", "index"))


class _Recorder:
    """Warm-up, capture and replay of one function, and the eager fallback when the capture fails.

    The first ``warmup`` calls run the function eagerly (on CUDA on a side stream, as torch.cuda.graphs
    asks); the next records it and replays it. A function that cannot be recorded (an operation that
    syncs with the host, say) logs one warning and runs eagerly from then on. Off CUDA it always runs
    eagerly (the unit tests' path).
    """

    what = "a step"

    def __init__(self, warmup: int) -> None:
        self.warmup = warmup
        self.captures = 0  # how often it was recorded (1 in a run without rollbacks or loads)
        self.eager = False  # True after a failed capture
        self.graph: torch.cuda.CUDAGraph | None = None
        self._warmup_left = warmup

    def _run(self, fn: Callable[..., Any], *args: Any, before_capture: Callable[[], None] | None = None) -> Any:
        """``fn(*args)``: replayed, recorded or eager (see the class); returns its outputs, which after the
        capture are the graph's buffers."""
        if self.graph is not None:
            if torch.cuda.current_device() == self._device.index:
                self.graph.replay()
            else:
                with torch.cuda.device(self._device):
                    self.graph.replay()
            return self._outputs
        device = next((a.device for a in args if isinstance(a, torch.Tensor) and a.is_cuda), None)
        if device is None or self.eager:  # no side stream: nothing will be recorded
            return self._eager_call(fn, args, before_capture, False)
        with torch.cuda.device(device):  # streams and graphs belong to the current device: make it the tensors'
            if self._warmup_left > 0:
                self._warmup_left -= 1
                return self._eager_call(fn, args, before_capture, True)
            if before_capture is not None:
                before_capture()
            graph = torch.cuda.CUDAGraph()
            try:
                with torch.cuda.graph(graph):
                    self._outputs = fn(*args)
            except RuntimeError as exc:  # an op that syncs with the host or cannot be recorded
                self.eager = True
                _log.warning(f"cuda_graph: could not capture {self.what} "
                             f"({' '.join(str(exc).split())[:200]}); it runs eagerly")
                return self._eager_call(fn, args, before_capture, True)
            self.graph, self._device = graph, device
            self.captures += 1
            _log.info(f"cuda_graph: captured {self.what} (capture {self.captures})")
            graph.replay()  # recording ran nothing: this is the call
            return self._outputs

    @staticmethod
    def _eager_call(fn: Callable[..., Any], args: tuple, before: Callable[[], None] | None, on_cuda: bool) -> Any:
        if before is not None:
            before()
        if not on_cuda:
            return fn(*args)
        side = torch.cuda.Stream()
        side.wait_stream(torch.cuda.current_stream())
        with torch.cuda.stream(side):
            out = fn(*args)
        torch.cuda.current_stream().wait_stream(side)
        return out


class GraphedStep(_Recorder):
    """Runs ``step_fn`` on static copies of each minibatch: eagerly for the first ``warmup`` calls, then as
    one captured CUDA graph. ``clear_grads`` runs before every eager call and before the recording (the agent
    sets its gradients to None, so backward starts from none and, recorded, allocates them in the graph's
    memory pool)."""

    what = "the PPO minibatch step"

    def __init__(self, step_fn: StepFn, clear_grads: Callable[[], None], warmup: int = WARMUP_STEPS) -> None:
        super().__init__(warmup)
        self.step_fn = step_fn
        self.clear_grads = clear_grads
        self.reset()

    def reset(self) -> None:
        """Forget the graph and its buffers: the next calls warm up and capture again (a failed capture
        stays eager)."""
        self.graph = None
        self._inputs: dict[str, torch.Tensor] | None = None
        self._outputs: tuple[torch.Tensor, torch.Tensor] | None = None
        self._warmup_left = self.warmup

    def __call__(self, batch: Batch, coef: torch.Tensor, reference: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """One minibatch step; returns (statistics, the policy's params), both owned by the graph after the
        capture: read or copy them before the next call."""
        inputs = self._load(batch, coef, reference)
        return self._run(self._call_step, inputs["coef"], inputs["reference"], before_capture=self.clear_grads)

    def _call_step(self, coef: torch.Tensor, reference: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.step_fn(_static_batch(self._inputs), coef, reference)

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
    not_finite = ~finite
    for param in params:
        if param.grad is not None:
            param.grad.masked_fill_(not_finite, 0.0)


class GraphedAct(_Recorder):
    """``act_fn(obs)`` (the model's act step) eagerly for the first ``warmup`` calls, then as one captured
    CUDA graph on a static copy of ``obs``. The returned dict holds the graph's buffers (overwritten by the
    next call) except the actions, which are a copy the env may keep."""

    what = "the rollout's act step"

    def __init__(self, act_fn: Callable[[torch.Tensor], dict], warmup: int = WARMUP_STEPS) -> None:
        super().__init__(warmup)
        self.act_fn = act_fn
        self._obs: torch.Tensor | None = None
        self._outputs: dict | None = None

    def __call__(self, obs: torch.Tensor) -> dict:
        if self._obs is None or self._obs.shape != obs.shape or self._obs.dtype != obs.dtype:
            self.graph, self._obs, self._warmup_left = None, torch.empty_like(obs), self.warmup
        self._obs.copy_(obs)
        out = self._run(self.act_fn, self._obs)
        if self.graph is None:
            return out
        return {**out, "actions": out["actions"].clone()}
