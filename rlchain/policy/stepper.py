"""Step-by-step inference for play, evaluation and video: carries RNN state, fetches action masks."""

from __future__ import annotations

from typing import Any

import torch

from rlchain.config.errors import ConfigError
from rlchain.envs.spec import EnvSpec, env_spec
from rlchain.envs.vecenv import VecEnv
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

    def uses_masks(self, spec: EnvSpec) -> bool:
        """Whether the model acts under action masks; a one-line ConfigError when it does and the env
        (its :class:`~rlchain.envs.spec.EnvSpec`) has none."""
        if not getattr(self.model, "use_action_masks", False):
            return False
        if not spec.action_masks:
            raise ConfigError("", "params.config.use_action_masks", "True, but the env played has no action "
                              "masks (has_action_mask() / get_action_mask())")
        return True

    def masks_from(self, env: VecEnv) -> torch.Tensor:
        """The env's current (B, mask_size) bool action masks on the model's device."""
        return torch.as_tensor(env.get_action_mask(), device=self.device).bool()

    def act(self, obs: torch.Tensor, env: VecEnv | None = None, deterministic: bool = True,
            masks: torch.Tensor | None = None) -> torch.Tensor:
        """Raw actions (B, ...) for ``obs`` under ``masks``; without them, masks come from
        ``env.get_action_mask()`` when the model uses masks and an env is given."""
        kwargs: dict = {"deterministic": deterministic}
        if masks is None and env is not None and self.uses_masks(env_spec(env)):
            masks = self.masks_from(env)
        if masks is not None:
            kwargs["action_masks"] = masks
        if self.states:
            kwargs["states"] = self.states
        out = self.model.act(obs, **kwargs)
        if self.states:
            self.states = tuple(out["states"])
        return out["actions"]

    def done(self, dones: torch.Tensor) -> None:
        """Zero the RNN states of rows whose episode just ended; ``dones`` is (B,) bool."""
        self.states = zero_finished(self.states, dones.to(self.device))
