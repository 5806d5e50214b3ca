"""V-trace for agents that are not always there: targets and advantages over each row's active steps.

The counterpart of :func:`rlchain.algos.multi_policy.masked.masked_gae` for appo / impala. A row (one agent of
one env) is active at step t when its agent acted at t; inactive steps carry no transition and are skipped:
the trace of an active step chains to the row's next active step, the rewards the agent got in between are
summed into it, and an episode end at an inactive step ends the chain there (bootstrapping its final
observation's value after a time-out). With every step active this is :func:`rlchain.algos.core.vtrace.vtrace`.
"""

from __future__ import annotations

import torch

from rlchain.algos.core.vtrace import VTrace


def masked_vtrace(log_rhos: torch.Tensor, rewards: torch.Tensor, values: torch.Tensor, final_values: torch.Tensor,
                  last_values: torch.Tensor, active: torch.Tensor, terminated: torch.Tensor, dones: torch.Tensor,
                  gamma: float, clip_rho: float | None = 1.0, clip_c: float | None = 1.0) -> VTrace:
    """V-trace over each row's active steps; every field zero at inactive steps.

    Shapes: ``log_rhos`` = log pi - log mu (T, N); rewards, values, final_values (T, N, V); last_values (N, V)
    (V of each row's observation after the rollout, the bootstrap); active, terminated, dones (T, N) bool, with
    the meaning :func:`~rlchain.algos.multi_policy.masked.masked_gae` gives them. ``clip_rho`` / ``clip_c``:
    rho-bar and c-bar (None: no clipping); the policy-gradient ratio is clipped by rho-bar too.
    """
    rhos = torch.exp(log_rhos).unsqueeze(-1)
    clipped = rhos if clip_rho is None else rhos.clamp(max=clip_rho)
    cs = rhos if clip_c is None else rhos.clamp(max=clip_c)
    zero = torch.zeros_like(last_values)
    next_value = last_values.clone()  # V of the row's next active step (or the bootstrap after an end)
    next_correction = zero.clone()  # v - V of the row's next active step (0 after an end)
    pending = zero.clone()  # rewards from this step up to the row's next active step
    corrections, advantages = torch.zeros_like(values), torch.zeros_like(values)
    for t in range(values.shape[0] - 1, -1, -1):
        done = dones[t].unsqueeze(-1)
        boot = torch.where(terminated[t].unsqueeze(-1), zero, final_values[t])
        next_value = torch.where(done, boot, next_value)
        next_correction = torch.where(done, zero, next_correction)
        pending = torch.where(done, zero, pending) + rewards[t]
        correction = clipped[t] * (pending + gamma * next_value - values[t]) + gamma * cs[t] * next_correction
        advantage = pending + gamma * (next_value + next_correction) - values[t]
        act = active[t].unsqueeze(-1)
        corrections[t] = torch.where(act, correction, zero)
        advantages[t] = torch.where(act, advantage, zero)
        next_value = torch.where(act, values[t], next_value)
        next_correction = torch.where(act, correction, next_correction)
        pending = torch.where(act, zero, pending)
    mask = active.unsqueeze(-1)
    vs = torch.where(mask, values + corrections, torch.zeros_like(values))
    ratios = torch.where(mask, rhos, 1.0).expand_as(values)
    return VTrace(vs, advantages, clipped.expand_as(values) * advantages, ratios)
