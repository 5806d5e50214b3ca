"""V-trace (Espeholt et al. 2018, "IMPALA"): off-policy value targets and policy-gradient advantages.

A pure function over a fragment of T steps of N envs, with time-outs kept apart from terminations
as :func:`rlchain.algos.core.returns.gae` does: ``next_values[t]`` is V(s_{t+1}) of the *true* next
state (the final observation when the episode ended at t, so a time-out bootstraps from it),
``terminated[t]`` zeroes that bootstrap, ``dones[t]`` (terminated or truncated) stops the trace
from flowing across the episode boundary.

With pi = mu (log-ratios 0) and no clipping, ``vs`` are the lambda-returns (lambda = 1: the
n-step returns bootstrapped at the end of the fragment) and ``advantages`` are GAE's.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass
class VTrace:
    """What :func:`vtrace` returns; every field has the shape of ``values`` ((T, N) or (T, N, V))."""

    vs: torch.Tensor
    """The V-trace value targets v_s."""
    advantages: torch.Tensor
    """q_t - V(s_t) with q_t = r_t + gamma * v_{t+1} (v_{t+1} = V(final obs) after a time-out, 0 after a
    termination): the advantage APPO's clipped surrogate weighs by pi / mu itself."""
    pg_advantages: torch.Tensor
    """min(clip_pg_rho, pi / mu) * advantages: IMPALA's policy-gradient advantage."""
    rhos: torch.Tensor
    """The importance ratios pi / mu (unclipped)."""


def vtrace(log_rhos: torch.Tensor, rewards: torch.Tensor, values: torch.Tensor, next_values: torch.Tensor,
           terminated: torch.Tensor, dones: torch.Tensor, gamma: float, clip_rho: float | None = 1.0,
           clip_c: float | None = 1.0, clip_pg_rho: float | None = None, lam: float = 1.0) -> VTrace:
    """V-trace targets and advantages of a fragment.

    Shapes: ``log_rhos`` = log pi(a|s) - log mu(a|s), ``terminated`` and ``dones`` (T, N); ``rewards``
    (T, N) or (T, N, V); ``values`` V(s_t) and ``next_values`` V(s_{t+1}) (see the module docstring),
    (T, N) or (T, N, V), raw scale. ``clip_rho`` (rho-bar) and ``clip_c`` (c-bar) clip the ratios
    of the TD errors and of the trace; None: no clipping. ``clip_pg_rho`` clips the ratio of
    ``pg_advantages`` (None: ``clip_rho``). ``lam`` scales the trace (c_t = lam * min(c-bar, rho_t)).

    The recursion, backwards from the fragment's end (where v_T = V(s_T), the bootstrap)::

        delta_t = min(rho-bar, rho_t) * (r_t + gamma * (1 - term_t) * V(s_{t+1}) - V(s_t))
        v_t - V(s_t) = delta_t + gamma * (1 - done_t) * c_t * (v_{t+1} - V(s_{t+1}))
    """
    values_like = values
    if values.dim() == rewards.dim() + 1:
        rewards = rewards.unsqueeze(-1)
    if log_rhos.dim() < values.dim():
        log_rhos = log_rhos.unsqueeze(-1)
    if terminated.dim() < values.dim():
        terminated = terminated.unsqueeze(-1)
        dones = dones.unsqueeze(-1)
    rhos = torch.exp(log_rhos)
    clipped_rhos = rhos if clip_rho is None else rhos.clamp(max=clip_rho)
    cs = lam * (rhos if clip_c is None else rhos.clamp(max=clip_c))
    not_terminal = 1.0 - terminated.to(values.dtype)
    not_done = 1.0 - dones.to(values.dtype)
    deltas = clipped_rhos * (rewards + gamma * not_terminal * next_values - values)
    corrections = torch.zeros_like(values)  # v_t - V(s_t)
    following = torch.zeros_like(values[0])  # v_{t+1} - V(s_{t+1}); 0 at the fragment's end
    for t in range(values.shape[0] - 1, -1, -1):
        following = deltas[t] + gamma * not_done[t] * cs[t] * following
        corrections[t] = following
    vs = values + corrections
    # v_{t+1}: the next step's target inside an episode; V(true next state) where it ended or at the end
    next_corrections = torch.cat([corrections[1:], torch.zeros_like(corrections[:1])], dim=0)
    next_vs = next_values + not_done * next_corrections
    advantages = rewards + gamma * not_terminal * next_vs - values
    pg_clip = clip_rho if clip_pg_rho is None else clip_pg_rho
    pg_rhos = rhos if pg_clip is None else rhos.clamp(max=pg_clip)
    shape = values_like.shape
    return VTrace(vs.reshape(shape), advantages.reshape(shape), (pg_rhos * advantages).reshape(shape),
                  rhos.expand_as(values).reshape(shape))
