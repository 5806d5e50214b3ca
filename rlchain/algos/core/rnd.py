"""Random network distillation (Burda et al. 2018; rsl_rl's ``rnd_cfg``): an intrinsic reward for novel states.

A target MLP with fixed random weights and a predictor MLP embed the (optionally normalized) observation; the
intrinsic reward of a state is ``weight * ||predictor(s) - target(s)||_2`` and the predictor is trained to
regress the target on the states seen, so the reward fades where the policy has been. The config block is
:class:`rlchain.config.exploration.RndConfig`; PPO adds the reward in its rollout and trains the predictor after
its update (rlchain/algos/ppo/ppo.py).
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn as nn

from rlchain.algos.core.optimizer_step import optimizer_step
from rlchain.models.normalization import EmpiricalNormalization


def mlp(inputs: int, units: list[int], outputs: int) -> nn.Sequential:
    """Linear + ELU layers of ``units``, then a linear output layer."""
    layers: list[nn.Module] = []
    for size in units:
        layers += [nn.Linear(inputs, size), nn.ELU()]
        inputs = size
    layers.append(nn.Linear(inputs, outputs))
    return nn.Sequential(*layers)


def parts_to_indices(parts: list | None, total: int) -> list[int] | None:
    """``rnd.obs`` (indices and 'start:stop' slices) as indices into a flat observation of ``total``;
    None = all of it. A bad part is a ValueError naming it."""
    if parts is None:
        return None
    indices: list[int] = []
    for part in parts:
        if isinstance(part, int) and not isinstance(part, bool):
            if not -total <= part < total:
                raise ValueError(f"index {part} is out of range for an observation of size {total}")
            indices.append(part % total)
        elif isinstance(part, str) and ":" in part:
            start, stop = (int(x) if x.strip() else None for x in part.split(":"))
            chosen = list(range(total))[start:stop]
            if not chosen:
                raise ValueError(f"slice '{part}' selects nothing of an observation of size {total}")
            indices += chosen
        else:
            raise ValueError(f"{part!r} is not an index or a 'start:stop' slice")
    return indices


class RandomNetworkDistillation(nn.Module):
    """Target and predictor of ``obs_size`` inputs (``indices`` of the observation, None = all); see the module
    docstring. ``reward`` (B, obs) -> (B,), ``fit`` trains the predictor on a batch and returns its loss."""

    def __init__(self, obs_size: int, cfg: Any, indices: list[int] | None = None,
                 device: torch.device | str = "cpu") -> None:
        super().__init__()
        self.weight = float(cfg.weight)
        self.register_buffer("indices", torch.tensor(indices if indices is not None else [], dtype=torch.long))
        size = len(indices) if indices is not None else obs_size
        self.normalizer = EmpiricalNormalization((size,)) if cfg.state_normalization else None
        self.target = mlp(size, list(cfg.target_units), int(cfg.num_outputs))
        self.predictor = mlp(size, list(cfg.predictor_units), int(cfg.num_outputs))
        for p in self.target.parameters():
            p.requires_grad_(False)
        self.to(device)
        self.optimizer = torch.optim.Adam(self.predictor.parameters(), lr=float(cfg.learning_rate))

    def state(self, obs: torch.Tensor) -> torch.Tensor:
        """The RND input of a batch of flat observations: the chosen part, normalized when on."""
        x = obs.float().flatten(1)
        if self.indices.numel():
            x = x.index_select(1, self.indices)
        return self.normalizer.normalize(x) if self.normalizer is not None else x

    @torch.no_grad()
    def observe(self, obs: torch.Tensor) -> None:
        """Fold a batch of observations into the input statistics (each rollout step, as rsl_rl)."""
        if self.normalizer is not None:
            x = obs.float().flatten(1)
            self.normalizer.update(x.index_select(1, self.indices) if self.indices.numel() else x)

    @torch.no_grad()
    def reward(self, obs: torch.Tensor) -> torch.Tensor:
        """(B,) intrinsic rewards: ``weight`` x the embedding distance."""
        x = self.state(obs)
        return self.weight * torch.linalg.vector_norm(self.predictor(x) - self.target(x), dim=1)

    def fit(self, obs: torch.Tensor) -> float:
        """One Adam step of the predictor towards the target on ``obs``; the MSE before the step."""
        with torch.no_grad():
            x = self.state(obs)
            goal = self.target(x)
        loss = nn.functional.mse_loss(self.predictor(x), goal)
        optimizer_step(self.optimizer, loss)
        return float(loss.detach())

    def train_on(self, obs: torch.Tensor, minibatch_size: int, passes: int,
                 generator: torch.Generator | None = None) -> float:
        """``passes`` shuffled passes of :meth:`fit` over the rows of ``obs`` in minibatches; the mean loss."""
        rows = obs.shape[0]
        losses = []
        for _ in range(passes):
            order = torch.randperm(rows, device=obs.device, generator=generator)
            for start in range(0, rows, minibatch_size):
                losses.append(self.fit(obs[order[start:start + minibatch_size]]))
        return sum(losses) / max(len(losses), 1)

    def full_state(self) -> dict[str, Any]:
        """Weights, input statistics and the predictor's optimizer (for checkpoints)."""
        return {"module": self.state_dict(), "optimizer": self.optimizer.state_dict()}

    def load_full_state(self, state: dict[str, Any]) -> None:
        self.load_state_dict(state["module"])
        self.optimizer.load_state_dict(state["optimizer"])
