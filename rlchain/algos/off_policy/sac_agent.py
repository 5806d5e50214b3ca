"""Soft actor-critic: the ``soft_actor_critic`` model (tanh-squashed Gaussian policy, twin critics,
target critics, temperature) and the SAC update."""

from __future__ import annotations

import copy
import math
from contextlib import nullcontext
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

from rlchain.algos.core.optimizer_step import optimizer_step
from rlchain.algos.core.precision import sac_autocast_dtype
from rlchain.algos.core.schedules import scale_lr
from rlchain.models.base import ObservationModel
from rlchain.models.distributions import BoxActions
from rlchain.models.normalization import obs_normalizer


def actor_params(actor: nn.Module, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(mu, log_std), each (B, A), of an actor: rlchain's returns them; rl_games' returns its tanh-squashed Normal,
    whose base distribution holds them."""
    out = actor(obs)
    if isinstance(out, tuple):
        return out
    base = getattr(out, "base_dist", out)
    return base.loc, base.scale.log()


def q_values(critic: nn.Module, obs: torch.Tensor, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """A twin critic's (q1, q2), each (B,) (rl_games' critics return (B, 1))."""
    q1, q2 = critic(obs, actions)
    return q1.reshape(q1.shape[0]), q2.reshape(q2.shape[0])


class SquashedActions(BoxActions):
    """The model's ``dist`` as the Player sees it: actions live in [-1, 1]; ``to_env`` rescales."""

    def __init__(self, space: gym.spaces.Box, clip_actions: bool) -> None:
        super().__init__(space, clip_actions)
        self.action_shape = tuple(space.shape)
        self.dim = int(np.prod(space.shape))
        self.action_dtype = torch.float32

    def mode(self, mean: torch.Tensor) -> torch.Tensor:
        """The deterministic action for a pre-squash mean: tanh(mean)."""
        return torch.tanh(mean)

    def random(self, n: int, device: torch.device) -> torch.Tensor:
        """Uniform actions in [-1, 1] (warmup)."""
        return torch.rand((n, *self.action_shape), device=device) * 2.0 - 1.0


class SoftActorCritic(ObservationModel):
    """network (``actor`` + ``critic``), ``critic_target``, ``log_alpha`` and the obs normalizer: Box actions
    (:class:`~rlchain.algos.off_policy.sac_discrete.DiscreteSoftActorCritic` for Discrete ones).

    The SAC update reaches the action space only through :meth:`taken_q` (the critics at the stored actions) and
    :meth:`soft_terms` (the policy's log-probability and Q at its own actions)."""

    flatten_obs = True

    def __init__(self, network: nn.Module, action_space: gym.Space, obs_shape: tuple[int, ...] | gym.spaces.Dict,
                 normalize_input: bool, init_alpha: float, clip_actions: bool = True,
                 log_std_bounds: list[float] | None = None, obs_normalizer_exclude: tuple[str, ...] = ()) -> None:
        super().__init__()
        if not hasattr(network, "actor") or not hasattr(network, "critic"):
            raise ValueError("params.network: soft_actor_critic needs a network with `actor` and `critic` "
                             "(use network name soft_actor_critic)")
        self.network = network
        if log_std_bounds is not None:
            network.actor.log_std_bounds = (float(log_std_bounds[0]), float(log_std_bounds[1]))
        self.critic_target = copy.deepcopy(network.critic)
        self.critic_target.requires_grad_(False)
        self.log_alpha = nn.Parameter(torch.tensor(math.log(init_alpha), dtype=torch.float32))
        self.dist = self.make_dist(action_space, clip_actions)
        # a Dict kept per key: images scaled, every other key not excluded by its own statistics
        self.running_mean_std = obs_normalizer(obs_shape, exclude=obs_normalizer_exclude) if normalize_input else None

    def make_dist(self, action_space: gym.Space, clip_actions: bool) -> SquashedActions:
        return SquashedActions(action_space, clip_actions)

    @property
    def default_target_entropy(self) -> float:
        """The temperature's entropy target when the config gives none: -action dims."""
        return -float(self.dist.dim)

    @property
    def alpha(self) -> torch.Tensor:
        return self.log_alpha.exp()

    def policy(self, obs: torch.Tensor, deterministic: bool = False) -> tuple[torch.Tensor, torch.Tensor]:
        """Preprocessed obs -> (actions in [-1, 1], log-prob (B,)); deterministic = tanh(mean)."""
        mu, log_std = actor_params(self.network.actor, obs)
        if deterministic:
            return torch.tanh(mu), torch.zeros(mu.shape[0], device=mu.device)
        std = log_std.exp()
        u = mu + std * torch.randn_like(mu)
        actions = torch.tanh(u)
        log_prob = (-0.5 * ((u - mu) / std).square() - log_std - 0.5 * math.log(2 * math.pi)).sum(-1)
        # log|d tanh(u)/du| = 2 (log 2 - u - softplus(-2u)), numerically stable
        log_prob = log_prob - (2.0 * (math.log(2.0) - u - F.softplus(-2.0 * u))).sum(-1)
        return actions, log_prob

    def soft_terms(self, critic: nn.Module, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(log pi(a|s), min(Q1, Q2)(s, a)), each (B,), at one action a sampled from the policy (reparameterized:
        gradients reach the actor through a); ``Q - alpha * log pi`` is the soft value's one-sample estimate."""
        actions, log_prob = self.policy(obs)
        q1, q2 = q_values(critic, obs, actions)
        return log_prob, torch.min(q1, q2)

    def taken_q(self, critic: nn.Module, obs: torch.Tensor, actions: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor]:
        """(q1, q2), each (B,), at the stored actions (B, A)."""
        return q_values(critic, obs, actions)

    def action_dist_inputs(self, obs: torch.Tensor) -> torch.Tensor:
        """Preprocessed obs -> the policy's distribution inputs in RLlib's layout, (B, 2A): the pre-tanh means
        then the log-stds (RLlib's ``TorchSquashedGaussian`` inputs)."""
        return torch.cat(actor_params(self.network.actor, obs), -1)

    def forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """obs -> (mean (B, A), value (B, 1)) in the ActorCritic protocol that export uses:
        ``dist.mode(mean)`` is the deterministic action, value = min(Q1, Q2) at that action."""
        x = self.preprocess(obs)
        mu, _ = actor_params(self.network.actor, x)
        q1, q2 = q_values(self.network.critic, x, torch.tanh(mu))
        return mu, torch.min(q1, q2).unsqueeze(-1)

    @torch.inference_mode()
    def act(self, obs: torch.Tensor, deterministic: bool = False) -> dict[str, torch.Tensor]:
        actions, log_prob = self.policy(self.preprocess(obs), deterministic)
        return {"actions": actions, "log_probs": log_prob}

    def override_sigma(self, sigma: float) -> None:
        raise ValueError("--sigma is not supported by soft_actor_critic (its std depends on the state)")


class SACAgent:
    """One SAC gradient step per :meth:`update` call (critic every call, actor + alpha every
    ``policy_frequency`` calls), then a Polyak update of the target critics."""

    rllib_stats = False
    """Also return the statistics only RLlib's results report (the first critic's loss, the temperature the step
    used, the mean |TD error|, the twin minimum's mean / max / min at the policy's actions); the RLlib face sets it
    on the agent it trains, so rlchain's own runs and the SB3 face pay for none of them."""

    def __init__(self, model: SoftActorCritic, cfg: Any) -> None:
        self.model, self.cfg = model, cfg
        net = model.network
        self.actor_opt = torch.optim.Adam(net.actor.parameters(), lr=cfg.actor_lr)
        self.critic_opt = torch.optim.Adam(net.critic.parameters(), lr=cfg.critic_lr)
        self.alpha_opt = torch.optim.Adam([model.log_alpha], lr=cfg.alpha_lr)
        self.target_entropy = float(cfg.target_entropy) if cfg.target_entropy is not None \
            else model.default_target_entropy
        self.updates = 0
        self.last: dict[str, float] = {"actor_loss": 0.0, "alpha_loss": 0.0, "entropy": 0.0}
        self._critic_params = list(net.critic.parameters())
        self._actor_params = list(net.actor.parameters())
        self._target_params = list(model.critic_target.parameters())
        device = next(model.parameters()).device
        self.amp_dtype = sac_autocast_dtype(getattr(cfg, "mixed_precision", False), device)

    def _autocast(self) -> Any:
        """The networks' forward passes of an update: bf16 autocast under ``mixed_precision`` on CUDA."""
        return torch.autocast("cuda", dtype=self.amp_dtype) if self.amp_dtype is not None else nullcontext()

    @property
    def lr(self) -> float:
        return self.actor_opt.param_groups[0]["lr"]

    def optimizers(self) -> dict[str, torch.optim.Optimizer]:
        """Each optimizer under the config key of its learning rate (get/set_params)."""
        return {"actor_lr": self.actor_opt, "critic_lr": self.critic_opt, "alpha_lr": self.alpha_opt}

    def scale_lr(self, factor: float) -> None:
        """Multiply the actor, critic and temperature learning rates (divergence rollback)."""
        for opt in (self.actor_opt, self.critic_opt, self.alpha_opt):
            scale_lr(opt, factor)

    def update(self, batch: dict[str, torch.Tensor]) -> tuple[dict[str, torch.Tensor], torch.Tensor]:
        """One step on a replay minibatch; returns (stats as 0-d tensors, |TD error| per sample)."""
        model, cfg = self.model, self.cfg
        critic = model.network.critic
        obs = model.preprocess(batch["obs"])
        next_obs = model.preprocess(batch["next_obs"])
        actions = batch["actions"]
        alpha = model.alpha.detach()
        with torch.no_grad():  # the soft value of the next observation under the target critics
            next_logp, next_q = model.soft_terms(model.critic_target, next_obs)
            next_v = next_q - alpha * next_logp
            target = batch["rewards"] + batch["discounts"] * (~batch["terminated"]).float() * next_v
        with self._autocast():  # the target above stays float32, as rl_games computes it
            q1, q2 = model.taken_q(critic, obs, actions)
        q1, q2 = q1.float(), q2.float()
        weights = batch["weights"]
        if getattr(cfg, "loss", "mse") == "huber":  # RLlib's: a Huber loss (delta 1) for each critic
            errors1, errors2 = F.huber_loss(q1, target, reduction="none"), F.huber_loss(q2, target, reduction="none")
        else:
            errors1, errors2 = (q1 - target).square(), (q2 - target).square()
        critic_loss = (weights * (errors1 + errors2)).mean()
        optimizer_step(self.critic_opt, critic_loss, params=self._critic_params, max_norm=cfg.grad_norm)
        td = 0.5 * ((q1 - target).abs() + (q2 - target).abs()).detach()

        stats = {"critic_loss": critic_loss.detach(), "q": q1.detach().mean()}
        if self.rllib_stats:
            # critic1_loss: the first critic's part of critic_loss (RLlib's qf_loss; the twin's is the rest);
            # alpha_used / log_alpha: the temperature this step used (0-d tensors: no host sync here)
            stats.update(critic1_loss=(weights * errors1.detach()).mean(), alpha_used=alpha,
                         log_alpha=model.log_alpha.detach().clone(), td_error=td.mean())
        if self.updates % cfg.policy_frequency == 0:
            critic.requires_grad_(False)
            with self._autocast():
                logp, q_pi = model.soft_terms(critic, obs)
            logp, q_pi = logp.float(), q_pi.float()
            actor_loss = (alpha * logp - q_pi).mean()
            optimizer_step(self.actor_opt, actor_loss, params=self._actor_params, max_norm=cfg.grad_norm)
            critic.requires_grad_(True)
            self.last["actor_loss"] = actor_loss.detach()
            self.last["entropy"] = -logp.detach().mean()
            if self.rllib_stats:  # the policy's actions' Q (RLlib's qf_mean / qf_max / qf_min)
                q_pi = q_pi.detach()
                self.last.update(q_pi=q_pi.mean(), q_pi_max=q_pi.max(), q_pi_min=q_pi.min())
            if cfg.learnable_temperature:
                alpha_loss = -(model.log_alpha * (logp.detach() + self.target_entropy)).mean()
                optimizer_step(self.alpha_opt, alpha_loss)
                self.last["alpha_loss"] = alpha_loss.detach()
        stats.update(self.last)
        with torch.no_grad():
            torch._foreach_lerp_(self._target_params, self._critic_params, cfg.critic_tau)
        self.updates += 1
        return stats, td

    def state_dict(self) -> dict[str, Any]:
        return {"actor_opt": self.actor_opt.state_dict(), "critic_opt": self.critic_opt.state_dict(),
                "alpha_opt": self.alpha_opt.state_dict(), "updates": self.updates}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.actor_opt.load_state_dict(state["actor_opt"])
        self.critic_opt.load_state_dict(state["critic_opt"])
        self.alpha_opt.load_state_dict(state["alpha_opt"])
        self.updates = int(state["updates"])
