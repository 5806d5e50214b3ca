"""rl_games' player classes, one per algorithm, all rlchain's :class:`~rlchain.rl_games.common.player.BasePlayer`
(the model's distribution, not the class, tells discrete from continuous)."""

from __future__ import annotations

from rlchain.rl_games.common.player import BasePlayer


class PpoPlayerContinuous(BasePlayer):
    """The player of ``a2c_continuous``."""


class PpoPlayerDiscrete(BasePlayer):
    """The player of ``a2c_discrete``."""


class SACPlayer(BasePlayer):
    """The player of ``sac``."""


PLAYERS: dict[str, type[BasePlayer]] = {"a2c_continuous": PpoPlayerContinuous, "a2c_discrete": PpoPlayerDiscrete,
                                        "sac": SACPlayer}
"""algo name -> player class (others get BasePlayer)."""

__all__ = ["PpoPlayerContinuous", "PpoPlayerDiscrete", "SACPlayer", "PLAYERS"]
