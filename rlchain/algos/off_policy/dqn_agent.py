"""DQN: the ``dqn`` model (Q-network, target network, epsilon-greedy acting) and the double-DQN update."""

from __future__ import annotations

import copy
from typing import Any

import gymnasium as gym
import torch
import torch.nn as nn
import torch.nn.functional as F

from rlchain.algos.core.optimizer_step import optimizer_step
from rlchain.algos.core.schedules import scale_lr
from rlchain.models.base import ObservationModel
from rlchain.models.normalization import obs_normalizer


class DiscreteActions:
    """The model's ``dist`` as the Player sees it: int64 actions (B,), passed to the env unchanged."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.action_shape: tuple[int, ...] = ()
        self.action_dtype = torch.long

    def to_env(self, actions: torch.Tensor) -> torch.Tensor:
        return actions

    def mode(self, q: torch.Tensor) -> torch.Tensor:
        """Greedy action for Q-values (B, n)."""
        return q.argmax(-1)

    def random(self, num: int, device: torch.device) -> torch.Tensor:
        return torch.randint(0, self.n, (num,), device=device)


class QModel(ObservationModel):
    """``network`` (obs -> Q (B, n)), ``target`` network, obs normalizer and the acting epsilon.

    ``act(obs, deterministic=True)`` is greedy; otherwise epsilon-greedy with the ``epsilon`` buffer
    (DQN sets it from its schedule; play uses ``play_epsilon``).
    """

    flatten_obs = True

    def __init__(self, network: nn.Module, n: int, obs_shape: tuple[int, ...] | gym.spaces.Dict, normalize_input: bool,
                 play_epsilon: float = 0.0, obs_normalizer_exclude: tuple[str, ...] = ()) -> None:
        super().__init__()
        self.network = network
        self.target = copy.deepcopy(network)
        self.target.requires_grad_(False)
        self.dist = DiscreteActions(n)
        # a Dict kept per key: images scaled, every other key not excluded by its own statistics
        self.running_mean_std = obs_normalizer(obs_shape, exclude=obs_normalizer_exclude) if normalize_input else None
        self.epsilon = float(play_epsilon)  # not saved: a checkpoint plays with the config's play_epsilon

    def q_values(self, obs: torch.Tensor) -> torch.Tensor:
        """obs -> Q (B, n)."""
        return self.network(self.preprocess(obs))

    def forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """obs -> (Q (B, n), max Q (B, 1)) in the ActorCritic protocol that export uses."""
        q = self.q_values(obs)
        return q, q.max(-1, keepdim=True).values

    @torch.inference_mode()
    def act(self, obs: torch.Tensor, deterministic: bool = False,
            epsilon: float | None = None) -> dict[str, torch.Tensor]:
        q = self.q_values(obs)
        actions = q.argmax(-1)
        if not deterministic:
            eps = float(self.epsilon) if epsilon is None else epsilon
            if eps > 0:
                explore = torch.rand(actions.shape[0], device=q.device) < eps
                actions = torch.where(explore, self.dist.random(actions.shape[0], q.device), actions)
        return {"actions": actions, "q": q}

    def override_sigma(self, sigma: float) -> None:
        raise ValueError("--sigma is not supported by DQN (discrete actions)")


class DQNAgent:
    """One (double) DQN gradient step per :meth:`update`; target update every target_update_frequency."""

    rllib_stats = False
    """Also return the statistics only RLlib's results report (the Q values' max and min, the mean |TD error|); the
    RLlib face sets it on the agent it trains, so rlchain's own runs and the SB3 face pay for none of them."""

    def __init__(self, model: QModel, cfg: Any) -> None:
        self.model, self.cfg = model, cfg
        self.opt = torch.optim.Adam(model.network.parameters(), lr=cfg.learning_rate)
        self.updates = 0
        self._online = list(model.network.parameters())
        self._target = list(model.target.parameters())

    @property
    def lr(self) -> float:
        return self.opt.param_groups[0]["lr"]

    def optimizers(self) -> dict[str, torch.optim.Optimizer]:
        """The optimizer under the config key of its learning rate (get/set_params)."""
        return {"learning_rate": self.opt}

    def scale_lr(self, factor: float) -> None:
        """Multiply the learning rate (divergence rollback)."""
        scale_lr(self.opt, factor)

    def update(self, batch: dict[str, torch.Tensor]) -> tuple[dict[str, torch.Tensor], torch.Tensor]:
        model, cfg = self.model, self.cfg
        obs = model.preprocess(batch["obs"])
        next_obs = model.preprocess(batch["next_obs"])
        actions = batch["actions"].long()
        with torch.no_grad():
            next_target_q = model.target(next_obs)
            if cfg.double_dqn:
                next_actions = model.network(next_obs).argmax(-1, keepdim=True)
            else:
                next_actions = next_target_q.argmax(-1, keepdim=True)
            next_q = next_target_q.gather(-1, next_actions).squeeze(-1)
            target = batch["rewards"] + batch["discounts"] * (~batch["terminated"]).float() * next_q
        q = model.network(obs).gather(-1, actions.unsqueeze(-1)).squeeze(-1)
        if cfg.loss == "huber":
            per_sample = F.smooth_l1_loss(q, target, reduction="none")
        else:
            per_sample = (q - target).square()
        loss = (batch["weights"] * per_sample).mean()
        optimizer_step(self.opt, loss, params=self._online, max_norm=cfg.grad_norm)
        self.updates += 1
        if self.updates % cfg.target_update_frequency == 0:
            with torch.no_grad():
                torch._foreach_lerp_(self._target, self._online, cfg.target_tau)
        q, td = q.detach(), (q - target).detach().abs()
        stats = {"td_loss": loss.detach(), "q": q.mean()}
        if self.rllib_stats:  # RLlib's qf_max, qf_min and td_error_mean (0-d tensors: no host sync here)
            stats.update(q_max=q.max(), q_min=q.min(), td_error=td.mean())
        return stats, td

    def state_dict(self) -> dict[str, Any]:
        return {"opt": self.opt.state_dict(), "updates": self.updates}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.opt.load_state_dict(state["opt"])
        self.updates = int(state["updates"])


def epsilon_at(frames_after_warmup: int, start: float, end: float, decay_frames: int) -> float:
    """Linear decay from ``start`` to ``end`` over ``decay_frames``, then constant."""
    frac = min(max(frames_after_warmup, 0) / decay_frames, 1.0)
    return start + frac * (end - start)


def dqn_model(network: nn.Module, action_space: gym.Space, obs_shape: tuple, value_size: int, config: Any,
              model_name: str) -> QModel:
    """MODELS factory ``dqn``."""
    if not isinstance(action_space, gym.spaces.Discrete):
        raise ValueError(f"params.model.name: dqn needs Discrete actions, the env has {action_space}")
    return QModel(network, int(action_space.n), obs_shape, getattr(config, "normalize_input", False),
                  getattr(config, "play_epsilon", 0.0), tuple(getattr(config, "obs_normalizer_exclude", ())))
