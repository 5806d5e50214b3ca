"""Advantages normalized by moving statistics (rl_games 2.0's ``normalize_rms_advantage``).

Instead of the batch's own mean and std, each epoch's advantages fold into exponential moving averages of
their mean and of their square (``decay`` = ``adv_rms_momentum``, rl_games' default 0.5), starting from zero
without bias correction, and are then normalized by them: (a - mean) / sqrt(max(E[a^2] - mean^2, 1e-10)),
clipped to +-5, as rl_games' ``GeneralizedMovingStats`` (``mean_std``) does.
"""

from __future__ import annotations

import torch

MIN_VAR = 1e-10  # rl_games: variance clamped to at least 1 / max^2 with max = 1e5
CLIP = 5.0


class MovingAdvantageStats:
    """EMA mean and mean square of the advantages; :meth:`normalize` updates, then normalizes."""

    def __init__(self, decay: float, device: torch.device | str = "cpu") -> None:
        self.decay = float(decay)
        self.mean = torch.zeros((), device=device)
        self.sqrs = torch.zeros((), device=device)
        self.step = 1

    def normalize(self, advantages: torch.Tensor, update: bool = True) -> torch.Tensor:
        """``advantages`` (any shape) folded into the statistics (when ``update``), then normalized by them."""
        if update:
            keep = self.decay
            self.mean = self.mean * keep + (1 - keep) * advantages.mean()
            self.sqrs = self.sqrs * keep + (1 - keep) * (advantages * advantages).mean()
            self.step += 1
        std = torch.sqrt(torch.clamp_min(self.sqrs - self.mean ** 2, MIN_VAR))
        return ((advantages - self.mean) / std).clamp(-CLIP, CLIP)

    def state_dict(self) -> dict:
        """rl_games' buffer names (``step``, ``mean``, ``sqrs``), as its checkpoints hold them."""
        return {"step": torch.tensor([self.step], dtype=torch.int32), "mean": self.mean.reshape(1).clone(),
                "sqrs": self.sqrs.reshape(1).clone()}

    def load_state_dict(self, state: dict) -> None:
        self.step = int(state["step"].reshape(-1)[0])
        self.mean = state["mean"].reshape(()).to(self.mean.device, torch.float32)
        self.sqrs = state["sqrs"].reshape(()).to(self.sqrs.device, torch.float32)
