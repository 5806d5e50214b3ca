"""GRPO on PPO's rollout and storage: no critic; group-relative advantages of per-step discounted returns,
the clipped surrogate over the alive steps, a k3 KL to a frozen copy of the initial policy (EmbodiChain's
algorithm). The rollout is PPO's (its OnPolicyCollector); each one starts from fresh episodes
(``reset_every_rollout``), optionally with every group's members on their leader's initial state
(``shared_starts``).

Under multi_gpu (torchrun) each rank steps its own ``num_actors`` envs, so a group's members are always on
one rank and each rank normalises its own groups, as EmbodiChain's distributed trainer does; the gradients
are averaged over the ranks before clipping."""

from __future__ import annotations

import copy
from functools import partial

import torch

from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import check_rollout
from rlchain.algos.core.losses import policy_loss
from rlchain.algos.core.optimizer_step import optimizer_step
from rlchain.algos.grpo.advantages import alive_mask, discounted_returns, group_advantages, k3_kl
from rlchain.algos.grpo.shared_starts import share_group_starts, supports_shared_starts
from rlchain.algos.ppo.ppo import PPO
from rlchain.config.errors import ConfigError
from rlchain.config.grpo import GRPOConfig
from rlchain.config.params import Params
from rlchain.envs.spec import EnvSpec
from rlchain.envs.vecenv import VecEnv
from rlchain.models.actor_critic import ActorCritic


class GRPO(PPO):
    """``algo: grpo`` (see the module docstring). The model's value head is built and never trained."""

    config_class = GRPOConfig
    metric_tags = {"a_loss": "losses/a_loss", "entropy": "losses/entropy", "ref_kl": "losses/ref_kl",
                   "lr": "info/last_lr", "kl": "info/kl", "clip_frac": "info/clip_frac",
                   "grad_norm": "info/grad_norm", "alive_frac": "info/alive_frac"}
    tunable = ("learning_rate", "entropy_coef", "e_clip", "grad_norm", "mini_epochs", "gamma", "kl_coef")
    supports_distributed = True  # groups are per rank (see the module docstring)
    self_play = False

    @classmethod
    def check_config(cls, params: Params, spec: EnvSpec) -> None:
        super().check_config(params, spec)
        if spec.num_agents != 1:
            raise ConfigError(params.source, "params.algo.name", "grpo trains single-agent envs")

    def __init__(self, params: Params, env: VecEnv, model: ActorCritic, ctx: RunContext) -> None:
        super().__init__(params, env, model, ctx)
        cfg = self.cfg
        if model.is_rnn:
            raise ConfigError(params.source, "params.network.rnn", "grpo trains feed-forward policies")
        if cfg.shared_starts and not supports_shared_starts(env):
            raise ConfigError(params.source, "params.config.shared_starts",
                              f"True needs an env whose get_state() holds its batch as tensors (rlchain's tensor "
                              f"envs); {type(env).__name__} has none")
        # the initial policy, frozen: copied at the first update (after torchrun's ranks took rank 0's
        # weights) or restored from a checkpoint
        self.reference: ActorCritic | None = None

    def _freeze_reference(self) -> ActorCritic:
        reference = copy.deepcopy(self.model).eval()
        for p in reference.parameters():
            p.requires_grad_(False)
        return reference

    def extra_state(self, kind: str) -> dict:
        out = super().extra_state(kind)
        if self.reference is not None:
            out["grpo_reference"] = self.reference.state_dict()
        return out

    def restore_extra(self, state: dict) -> None:
        super().restore_extra(state)
        if self.cfg.kl_coef > 0 and "grpo_reference" in state:
            self.reference = self._freeze_reference()
            self.reference.load_state_dict(state["grpo_reference"])

    def collect(self) -> bool:
        """Fresh episodes for every env (shared within groups with ``shared_starts``), then PPO's rollout."""
        cfg = self.cfg
        collector = self.collector
        if cfg.reset_every_rollout and self.ctx.epoch > 0 or cfg.shared_starts:
            self.ctx.tracker.reset_running()
            obs = self.ctx.reset_envs()
            collector.reset_states()
            if cfg.shared_starts:
                obs = share_group_starts(self.env, obs, cfg.group_size)
            collector.place(obs)
        return collector.rollout()

    def update(self) -> dict[str, float]:
        """Group-relative advantages, then ``mini_epochs`` passes of masked clipped-surrogate minibatches."""
        cfg, storage, model = self.cfg, self.storage, self.model
        check_rollout(storage.rewards, storage.obs)
        if cfg.kl_coef > 0 and self.reference is None:
            self.reference = self._freeze_reference()
        comm = self.ctx.comm
        with torch.no_grad():
            rewards = storage.rewards.sum(-1)
            mask = alive_mask(storage.dones, cfg.truncate_at_first_done)
            advantages = group_advantages(discounted_returns(rewards, storage.dones, cfg.gamma), mask,
                                          cfg.group_size, cfg.eps)
            flat_mask = mask.reshape(-1)
        model.train()
        agent, dist = self.agent, model.dist
        sums = {"a_loss": 0.0, "entropy": 0.0, "ref_kl": 0.0, "kl": 0.0, "clip_frac": 0.0, "grad_norm": 0.0}
        count = 0
        for _ in range(cfg.mini_epochs):
            for batch in storage.minibatches(cfg.minibatch_size, advantages):
                weight = flat_mask[batch.index]
                denom = weight.sum().clamp(min=1.0)
                params, _, _ = model.evaluate(batch.obs)
                log_probs, entropy = dist.log_prob_and_entropy(params, batch.actions)
                a_loss = (policy_loss(batch.log_probs, log_probs, batch.advantages, cfg.e_clip) * weight).sum() / denom
                mean_entropy = (entropy * weight).sum() / denom
                loss = a_loss - agent.entropy_coef * mean_entropy
                ref_kl = torch.zeros((), device=loss.device)
                if self.reference is not None:
                    with torch.no_grad():
                        ref_params, _, _ = self.reference.evaluate(batch.obs)
                        ref_log_probs = dist.log_prob(ref_params, batch.actions)
                    ref_kl = (k3_kl(log_probs, ref_log_probs) * weight).sum() / denom
                    loss = loss + cfg.kl_coef * ref_kl
                with torch.no_grad():
                    kl = dist.kl(batch.params, params.detach()).mean()
                    ratio = torch.exp(log_probs.detach() - batch.log_probs)
                    clip_frac = ((ratio - 1.0).abs() > cfg.e_clip).float().mean()
                step = optimizer_step(agent.optimizer, loss, params=agent.params, comm=comm, what="the GRPO update",
                                      max_norm=cfg.grad_norm if cfg.truncate_grads else None,
                                      stats=partial(_read_stats, a_loss, mean_entropy, ref_kl, kl, clip_frac))
                for key, value in step.items():
                    sums[key] += value
                count += 1
        agent.apply_progress(self.progress())
        stats = {key: value / max(count, 1) for key, value in sums.items()}
        stats.update(lr=agent.lr, entropy_coef=agent.entropy_coef, alive_frac=float(mask.mean()))
        stats["lr0"] = cfg.learning_rate
        stats["lr_mul"] = stats["lr"] / max(cfg.learning_rate, 1e-12)
        return stats


def _read_stats(a_loss: torch.Tensor, entropy: torch.Tensor, ref_kl: torch.Tensor, kl: torch.Tensor,
                clip_frac: torch.Tensor, grad_norm: torch.Tensor | None) -> dict[str, float]:
    """A GRPO step's statistics, read back with one host sync (grad_norm 0 when the gradients are not clipped)."""
    values = torch.stack([a_loss.detach(), entropy.detach(), ref_kl.detach(), kl, clip_frac,
                          torch.zeros_like(kl) if grad_norm is None else grad_norm.detach()]).tolist()
    return dict(zip(("a_loss", "entropy", "ref_kl", "kl", "clip_frac", "grad_norm"), values))
