"""The one optimizer step every algorithm takes: zero the gradients, backward, average them over ranks, unscale
(float16's grad scaler), clip, check the step is finite, step. PPO, its central value, GRPO, APG,
distillation, SAC, DQN, the RND predictor and the mirror loss all step through :func:`optimizer_step`."""

from __future__ import annotations

import math
from collections.abc import Callable

import torch

from rlchain.algos.core.fused_adam_step import fused_adam_step
from rlchain.errors import DivergenceError, first_non_finite
from rlchain.parallel.communicator import SINGLE, Communicator

StepStats = Callable[[torch.Tensor | None], dict[str, float]]
"""(the gradients' global norm, None when not clipped) -> the step's statistics by name, read from the device."""


def optimizer_step(optimizer: torch.optim.Optimizer, loss: torch.Tensor, *,
                   params: list[torch.nn.Parameter] | None = None, max_norm: float | None = None,
                   comm: Communicator = SINGLE,
                   scaler: torch.amp.GradScaler | None = None, stats: StepStats | None = None,
                   what: str = "the update") -> dict[str, float] | None:
    """One gradient step of ``optimizer`` on ``loss``; returns ``stats``' result (None without ``stats``).

    ``params``: the optimizer's parameters (all of its groups' when None), which the gradients are averaged and
    clipped over. In order: the gradients to None, backward (the loss scaled by ``scaler``), the gradients
    averaged over the ranks (multi_gpu: before unscaling and clipping, so every rank steps the same), unscaled,
    clipped to the global norm ``max_norm`` (``inf``: the norm measured, nothing clipped; None: neither), then
    ``stats`` read with the step's one host sync. A non-finite statistic raises DivergenceError naming it and
    ``what`` before the step: the parameters stay as they were and the gradients are dropped. With a grad
    scaler nothing raises (the scaler skips a step with inf gradients itself). Without ``stats`` nothing is
    checked and nothing waits for the device (SAC's and DQN's many small steps: the Loop checks the parameters
    after the epoch).
    """
    clear_grads(optimizer)
    (loss if scaler is None else scaler.scale(loss)).backward()
    if params is None and (comm.active or max_norm is not None):
        params = [p for group in optimizer.param_groups for p in group["params"]]
    if comm.active:
        comm.average_gradients(params)
    if scaler is not None:
        scaler.unscale_(optimizer)
    grad_norm = None if max_norm is None else clip_grad_norm(params, max_norm)
    values = None
    if stats is not None:
        values = stats(grad_norm)
        if scaler is None:  # a grad scaler skips a step with inf gradients itself
            check_finite(values, what, optimizer)
    if scaler is not None:
        scaler.step(optimizer)
        scaler.update()
    elif not fused_adam_step(optimizer):  # torch's fused Adam kernel without its wrapper, where that applies
        optimizer.step()
    return values


def clip_grad_norm(params: list[torch.nn.Parameter], max_norm: float) -> torch.Tensor:
    """``torch.nn.utils.clip_grad_norm_``: the gradients' global norm, the gradients clipped to ``max_norm``.

    With ``max_norm`` inf only the norm is measured: torch would multiply every gradient by its clip
    coefficient, clamped to 1.0, which changes no finite value (one pass over the gradients less per step).
    A non-finite norm would have made them NaN; the step's statistics then raise before the step, and with a
    grad scaler the scaler skips that step on the inf it found while unscaling, so nothing trains on them either.
    """
    total_norm = getattr(torch.nn.utils, "get_total_norm", None)  # torch >= 2.6
    if math.isinf(max_norm) and max_norm > 0 and total_norm is not None:
        grads = [p.grad for p in params if p.grad is not None]
        plain = grads and grads[0].device.type == "cpu" and all(
            type(g) is torch.Tensor and g.device == grads[0].device and g.dtype == grads[0].dtype and not g.is_sparse
            for g in grads)
        if plain:  # get_total_norm's two ops for one CPU device and dtype, without its wrappers' per-call overhead
            with torch.no_grad():
                return torch.linalg.vector_norm(torch.stack(torch._foreach_norm(grads, 2.0)), 2.0)
        return total_norm(grads)
    return torch.nn.utils.clip_grad_norm_(params, max_norm)


def check_finite(values: dict[str, float], what: str, optimizer: torch.optim.Optimizer | None = None) -> None:
    """The non-finite check of a step: DivergenceError naming the first NaN / inf statistic and ``what``
    (``optimizer``'s gradients dropped first, when given)."""
    bad = first_non_finite(values)
    if bad is not None:
        if optimizer is not None:
            optimizer.zero_grad(set_to_none=True)
        raise DivergenceError(f"{bad} in {what}")


def clear_grads(optimizer: torch.optim.Optimizer) -> None:
    """The gradients of ``optimizer``'s parameters to None (the next backward pass allocates them): what torch's
    ``zero_grad(set_to_none=True)`` does, without its profiler range where the optimizer does not override it."""
    if type(optimizer).zero_grad is not torch.optim.Optimizer.zero_grad:
        optimizer.zero_grad(set_to_none=True)
        return
    for group in optimizer.param_groups:
        for p in group["params"]:
            p.grad = None
