"""Step-by-step inference for play, evaluation and video: carries RNN state, fetches action masks."""

from __future__ import annotations

from typing import Any

import torch

from rlchain.config.errors import ConfigError
from rlchain.networks.rnn import zero_finished


class PolicyStepper:
    """Acts on ``num_envs`` envs one step at a time with an ActorCritic-like model.

    It keeps the RNN states between calls (zeroed for rows whose episode ended, see :meth:`done`)
    and, when the model uses action masks, asks the env for them before every step.
    """

    def __init__(self, model: Any, num_envs: int, device: torch.device) -> None:
        self.model = model
        self.device = device
        self.num_envs = num_envs
        self.states = self._initial(num_envs)

    def _initial(self, batch: int) -> tuple:
        init = getattr(self.model, "initial_state", None)
        return tuple(init(batch, self.device)) if callable(init) else ()

    def reset(self) -> None:
        """Forget all memory (new episodes everywhere)."""
        self.states = self._initial(self.num_envs)

    def act(self, obs: torch.Tensor, env: Any = None, deterministic: bool = True) -> torch.Tensor:
        """Raw actions (B, ...) for ``obs``; masks come from ``env.get_action_mask()`` when used."""
        kwargs: dict = {"deterministic": deterministic}
        if getattr(self.model, "use_action_masks", False) and env is not None:
            has = getattr(env, "has_action_mask", None)
            if not callable(getattr(env, "get_action_mask", None)) or (callable(has) and not has()):
                raise ConfigError("", "params.config.use_action_masks", "True, but the env played has no action "
                                  "masks (has_action_mask() / get_action_mask())")
            kwargs["action_masks"] = torch.as_tensor(env.get_action_mask(), device=self.device).bool()
        if self.states:
            kwargs["states"] = self.states
        out = self.model.act(obs, **kwargs)
        if self.states:
            self.states = tuple(out["states"])
        return out["actions"]

    def done(self, dones: torch.Tensor) -> None:
        """Zero the RNN states of rows whose episode just ended; ``dones`` is (B,) bool."""
        self.states = zero_finished(self.states, dones.to(self.device))
