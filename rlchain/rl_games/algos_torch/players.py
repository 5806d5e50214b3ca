"""rl_games' player classes, one per algorithm, all rlchain's :class:`~rlchain.rl_games.common.player.BasePlayer`
(the model's distribution, not the class, tells discrete from continuous)."""

from __future__ import annotations

from typing import Any

import torch
import torch.nn as nn

from rlchain.rl_games.algos_torch.models import ModelSACContinuous
from rlchain.rl_games.algos_torch.sac_helper import SquashedNormal
from rlchain.rl_games.common.player import BasePlayer


class PpoPlayerContinuous(BasePlayer):
    """The player of ``a2c_continuous``."""


class PpoPlayerDiscrete(BasePlayer):
    """The player of ``a2c_discrete``."""


class SACNetworkParts(nn.Module):
    """rl_games' ``sac_network``: the ``actor``, ``critic`` and ``critic_target`` modules of the player's
    rlchain model (the same modules, so a restore into one is seen by the other)."""

    def __init__(self, actor: nn.Module, critic: nn.Module, critic_target: nn.Module) -> None:
        super().__init__()
        self.actor, self.critic, self.critic_target = actor, critic, critic_target

    def is_rnn(self) -> bool:
        return False


class SACModelView(ModelSACContinuous.Network):
    """rl_games' SAC model over rlchain's: ``norm_obs(obs)``, ``actor(obs)`` -> the tanh-squashed Normal (its
    ``mean`` is the deterministic action in [-1, 1]), ``critic`` / ``critic_target(obs, action)`` -> (q1, q2),
    each (B, 1), ``sac_network``, ``forward({'obs': ...})`` -> the distribution, ``is_rnn()``."""

    def __init__(self, policy: nn.Module, obs_shape: Any, value_size: int) -> None:
        network = policy.network
        super().__init__(SACNetworkParts(network.actor, network.critic, policy.critic_target), obs_shape=obs_shape,
                         normalize_value=False, normalize_input=False, value_size=value_size)
        self.normalize_input = policy.running_mean_std is not None
        self._preprocess = policy.preprocess  # a bound method: the normalizer stays rlchain's model's alone

    def norm_obs(self, observation: torch.Tensor) -> torch.Tensor:
        """The actor's input, normalized by the trained statistics when ``normalize_input``."""
        with torch.no_grad():
            return self._preprocess(observation)

    def actor(self, obs: torch.Tensor) -> SquashedNormal:
        out = self.sac_network.actor(obs)
        if isinstance(out, tuple):  # rlchain's actor: (mu, log_std)
            mu, log_std = out
            return SquashedNormal(mu, log_std.exp())
        return out  # a network written the rl_games way returns its distribution

    def critic(self, obs: torch.Tensor, action: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return _twin_q(self.sac_network.critic, obs, action)

    def critic_target(self, obs: torch.Tensor, action: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return _twin_q(self.sac_network.critic_target, obs, action)

    def forward(self, input_dict: dict) -> SquashedNormal:
        return self.actor(input_dict["obs"])


def _twin_q(critic: nn.Module, obs: torch.Tensor, action: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(q1, q2), each (B, 1) as rl_games' critics return them (rlchain's return (B,))."""
    q1, q2 = critic(obs, action)
    return q1.reshape(q1.shape[0], -1), q2.reshape(q2.shape[0], -1)


class SACPlayer(BasePlayer):
    """The player of ``sac``: ``model`` is rl_games' SAC model (:class:`SACModelView`); ``action_low`` /
    ``action_high`` / ``action_scale`` / ``action_bias`` (per dimension) and ``actions_num`` as rl_games 2.0's."""

    def __init__(self, params: dict[str, Any], parsed: Any = None) -> None:
        super().__init__(params, parsed)
        space = self.action_space
        self.actions_num = int(space.shape[0])
        self.action_range = [float(space.low.min()), float(space.high.max())]
        self.action_low = torch.as_tensor(space.low, dtype=torch.float32, device=self.device)
        self.action_high = torch.as_tensor(space.high, dtype=torch.float32, device=self.device)
        self.action_scale = (self.action_high - self.action_low) / 2.0
        self.action_bias = (self.action_high + self.action_low) / 2.0

    def rl_games_model(self, policy: nn.Module) -> nn.Module:
        return SACModelView(policy, self.obs_shape, self.value_size)

    def rescale_actions(self, actions: torch.Tensor) -> torch.Tensor:
        """Squashed actions in [-1, 1] as the env's Box takes them, per dimension (low + (a + 1) (high - low) / 2),
        clamped to the box (rl_games 2.0's SAC player; ``get_action`` already returns env actions)."""
        space = self.action_space
        low = torch.as_tensor(space.low, dtype=actions.dtype, device=actions.device)
        high = torch.as_tensor(space.high, dtype=actions.dtype, device=actions.device)
        return torch.maximum(torch.minimum(low + (actions + 1.0) * 0.5 * (high - low), high), low)


PLAYERS: dict[str, type[BasePlayer]] = {"a2c_continuous": PpoPlayerContinuous, "a2c_discrete": PpoPlayerDiscrete,
                                        "sac": SACPlayer}
"""algo name -> player class (others get BasePlayer)."""

__all__ = ["PpoPlayerContinuous", "PpoPlayerDiscrete", "SACPlayer", "SACModelView", "SACNetworkParts", "PLAYERS"]
