"""rl_games' player classes, one per algorithm, all rlchain's :class:`~rlchain.rl_games.common.player.BasePlayer`
(the model's distribution, not the class, tells discrete from continuous)."""

from __future__ import annotations

import torch

from rlchain.rl_games.common.player import BasePlayer


class PpoPlayerContinuous(BasePlayer):
    """The player of ``a2c_continuous``."""


class PpoPlayerDiscrete(BasePlayer):
    """The player of ``a2c_discrete``."""


class SACPlayer(BasePlayer):
    """The player of ``sac``."""

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

__all__ = ["PpoPlayerContinuous", "PpoPlayerDiscrete", "SACPlayer", "PLAYERS"]
