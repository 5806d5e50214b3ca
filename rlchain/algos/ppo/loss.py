"""PPO's minibatch loss: one forward pass of the actor-critic, then the policy, value, entropy, bounds and
auxiliary losses and the step's statistics.

:func:`ppo_loss` has no side effects and no host syncs: it is the region ``compile_update`` compiles (with
the backward pass AOTAutograd derives from it) and part of what ``cuda_graph`` captures. The per-sample
terms it sums are the pure functions of :mod:`rlchain.algos.core.losses`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from contextlib import nullcontext

import torch

from rlchain.algos.core.losses import (
    aux_loss_terms,
    normalize_advantages,
    policy_loss_grad,
    value_loss,
    value_loss_grad,
)
from rlchain.algos.core.storage import Batch
from rlchain.algos.ppo.analytic_step import AnalyticStep, analytic_step
from rlchain.config.ppo import PPOConfig
from rlchain.models.actor_critic import ActorCritic

STEP_STATS = ("a_loss", "c_loss", "entropy", "b_loss", "clip_frac", "kl", "loss", "grad_norm")
"""The statistics of a minibatch step, in the order of its statistics vector (auxiliary losses follow)."""

Surrogate = Callable[[torch.Tensor, torch.Tensor, torch.Tensor, float, bool], torch.Tensor]
"""(rollout log-probs (B,), current log-probs (B,), advantages (B,), e_clip, smooth clamp) -> per-sample policy
loss (B,): :func:`rlchain.algos.core.losses.policy_loss`, PPO's clipped surrogate (IMPALA's has no clip)."""

LossOutput = tuple[torch.Tensor, torch.Tensor, dict[str, torch.Tensor], torch.Tensor]
"""(loss (0-d), detached statistics (6,), the network's auxiliary losses, the policy's params (B, P), detached)."""


def squared_error_clamped(values: torch.Tensor, returns: torch.Tensor, limit: float) -> torch.Tensor:
    """Per-sample squared value error clamped to [0, limit] (RLlib's ``vf_clip_param``: the loss itself is
    clipped, so a sample further than sqrt(limit) from its return gives no gradient). Shapes (B, V) -> (B,)."""
    return (values - returns).square().clamp(0.0, limit).sum(-1)


def squared_error_clamped_grad(values: torch.Tensor, returns: torch.Tensor, limit: float) -> torch.Tensor:
    """d :func:`squared_error_clamped` / d values (B, V): 2 * (values - returns) where the squared error is
    at most ``limit`` (the clamp passes its bound, as autograd's clamp does), else 0."""
    error = values - returns
    return (2.0 * error).mul_(error.square() <= limit)


def adapted_kl_coef(coef: float, kl: float, target: float) -> float:
    """RLlib's adaptive KL coefficient after an update whose KL was ``kl``: x1.5 above twice the target,
    x0.5 below half of it, unchanged in between (a non-finite KL leaves it unchanged)."""
    if kl > 2.0 * target:
        return coef * 1.5
    if kl < 0.5 * target:
        return coef * 0.5
    return coef


def ppo_loss(model: ActorCritic, cfg: PPOConfig, batch: Batch, entropy_coef: torch.Tensor, reference: torch.Tensor,
             surrogate: Surrogate, train_critic: bool = True, amp_dtype: torch.dtype | None = None,
             device_type: str = "cpu", autocast_cache: bool = True,
             kl_coef: torch.Tensor | None = None) -> LossOutput:
    """One minibatch's forward pass and losses.

    Returns (loss, the detached statistics a_loss, c_loss, entropy, b_loss, clip_frac, kl as one (6,) vector,
    the network's auxiliary losses by name, the policy's params (B, param_size), detached). ``reference``
    (B, param_size) is the distribution the KL is measured against; ``entropy_coef`` a 0-d tensor, so a
    scheduled coefficient does not recompile a compiled caller. ``train_critic`` False (a central value
    network trains the values) leaves the value loss out. Under ``amp_dtype`` the network's forward pass runs
    in autocast (its cache off with ``autocast_cache`` False, as a captured graph needs) and its outputs are
    cast back to float32, so the log-probs, ratios, KL and losses are computed in float32 against the
    rollout's float32 log-probs. ``kl_coef`` (a 0-d tensor; None or with ``cfg.kl_loss_coef`` 0: off) adds
    RLlib's KL penalty, ``kl_coef * mean KL(reference || current)``, with its gradient. ``cfg.value_loss_clip`` replaces
    the squared value error with :func:`squared_error_clamped` (RLlib's ``vf_clip_param``).
    """
    dist = model.dist
    amp = amp_dtype is not None
    # the plain case (rlchain.algos.ppo.analytic_step): the forward pass without a graph, the gradients written out
    step = analytic_step(model, batch, surrogate, train_critic, amp_dtype, cfg.use_smooth_clamp)
    traced = step.forward(model.preprocess(batch.obs)) if step is not None else None
    if traced is not None:
        params, values = dist.params_from_network(traced[0])
        aux = {}
    else:
        autocast = torch.autocast(device_type, dtype=amp_dtype, cache_enabled=autocast_cache) if amp \
            else nullcontext()
        with autocast:
            params, values, _ = model.evaluate(batch.obs, batch.states, batch.resets, batch.seq_length,
                                               batch.action_masks, batch.actions)
            aux = aux_loss_terms(model.aux_losses())  # {} for a network without get_aux_loss()
    if amp:
        params, values = params.float(), values.float()
        aux = {name: value.float() for name, value in aux.items()}
    mean = _mean_over(batch.weights)
    log_probs, entropy = dist.log_prob_and_entropy(params, batch.actions)
    entropy = mean(entropy)
    advantages = batch.advantages
    if cfg.normalize_advantage and cfg.advantage_normalization == "minibatch" and advantages.numel() > 1:
        advantages = normalize_advantages(advantages)  # Stable-Baselines3's: per minibatch
    policy_terms = surrogate(batch.log_probs, log_probs, advantages, cfg.e_clip, cfg.use_smooth_clamp)
    a_loss = mean(policy_terms)
    clip = getattr(cfg, "value_loss_clip", None)  # PPOConfig's; APPO / IMPALA configs have none
    returns = model.norm_value(batch.returns) if train_critic else None
    old_values = model.norm_value(batch.values) if train_critic and clip is None else None
    if train_critic and clip is not None:
        c_loss = mean(squared_error_clamped(values, returns, clip))
    elif train_critic:
        c_loss = mean(value_loss(values, old_values, returns, cfg.e_clip, cfg.clip_value))
    else:
        c_loss = torch.zeros((), device=values.device)
    loss = a_loss + 0.5 * cfg.critic_coef * c_loss - entropy_coef * entropy
    b_loss = torch.zeros((), device=params.device)
    if cfg.bounds_loss_coef:
        b_loss = mean(dist.bounds_loss(params, cfg.bound_loss_type))
        loss = loss + cfg.bounds_loss_coef * b_loss
    for aux_loss in aux.values():
        loss = loss + aux_loss
    penalty = kl_coef is not None  # the agent passes it only with kl_loss_coef > 0
    if penalty:  # RLlib's KL penalty: its gradient flows into the current policy's params
        kl = mean(dist.kl(reference, params.float()))
        loss = loss + kl_coef * kl
    with torch.no_grad():
        current = params.detach().float()
        kl = kl.detach() if penalty else mean(dist.kl(reference, current))
        ratio = torch.exp(log_probs.detach() - batch.log_probs)
        clip_frac = mean(((ratio - 1.0).abs() > cfg.e_clip).float())
    if traced is not None:
        g_values = squared_error_clamped_grad(values, returns, clip) if clip is not None \
            else value_loss_grad(values, old_values, returns, cfg.e_clip, cfg.clip_value)
        loss = step.attach(loss, traced[1], _output_grads(step, cfg, batch, params, g_values, ratio, advantages,
                                                         policy_terms, entropy_coef, reference, kl_coef))
    stats = torch.stack([a_loss.detach().float(), c_loss.detach().float(), entropy.detach().float(),
                         b_loss.detach().float(), clip_frac, kl.float()])
    return loss, stats, aux, current


def _output_grads(step: AnalyticStep, cfg: PPOConfig, batch: Batch, params: torch.Tensor, g_values: torch.Tensor,
                  ratio: torch.Tensor, advantages: torch.Tensor, policy_terms: torch.Tensor,
                  entropy_coef: torch.Tensor, reference: torch.Tensor, kl_coef: torch.Tensor | None
                  ) -> tuple[torch.Tensor, ...]:
    """d loss / d each of the network's outputs (policy outputs, then values) for :func:`ppo_loss`'s loss in the
    plain case, ``g_values`` the value loss's per-row derivative: each term's derivative, the means' 1 / B and
    the coefficients applied."""
    per_row = 1.0 / ratio.shape[0]
    g_log_prob = policy_loss_grad(ratio, advantages, policy_terms).mul_(per_row)
    g_values = g_values.mul_(0.5 * cfg.critic_coef * per_row)
    penalty = kl_coef is not None
    bounds = (cfg.bound_loss_type, cfg.bounds_loss_coef * per_row) if cfg.bounds_loss_coef else None
    policy = step.grads.network_grads(params, batch.actions, g_log_prob, entropy_coef * -per_row,
                                      reference if penalty else None, kl_coef * per_row if penalty else None, bounds)
    return (*policy, g_values)


def _mean_over(weights: torch.Tensor | None) -> Callable[[torch.Tensor], torch.Tensor]:
    """The mean of per-row terms (B,): plain, or weighted by ``weights`` (B,) (rows of weight 0 left out)."""
    if weights is None:
        return torch.mean
    total = weights.sum().clamp_min(1.0)
    return lambda x: (x * weights).sum() / total


def stats_vector(loss: torch.Tensor, stats: torch.Tensor, aux: dict[str, torch.Tensor],
                 grad_norm: torch.Tensor) -> torch.Tensor:
    """A step's statistics as one float32 vector in :data:`STEP_STATS` order, the auxiliary losses after."""
    return torch.cat([stats, torch.stack([loss.detach().float(), grad_norm.detach().float(),
                                          *(value.detach().float() for value in aux.values())])])


def named_stats(values: list[float], aux_names: Iterable[str]) -> dict[str, float]:
    """A step's statistics vector (read back) by name: :data:`STEP_STATS`, then ``losses/<name>``."""
    return dict(zip((*STEP_STATS, *(f"losses/{name}" for name in aux_names)), values))
