"""Per-policy pieces of multi-policy PPO: the models (one per policy), each policy's rows of the
PettingZoo env, its learner (agent, rollout storage, active mask) and its episode statistics."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from rlchain.algos.base.episodes import AgentEpisodes
from rlchain.algos.core.storage import RolloutStorage
from rlchain.algos.multi_policy.masked import MaskedPPOAgent
from rlchain.config.params import Params
from rlchain.runs.checkpoint import CheckpointError


class PolicyLearner:
    """One policy: its model, its agents' rows (agent-major: row ``k * E + e`` is agent k of env e)
    and, when it trains, a :class:`MaskedPPOAgent`, a rollout storage and the (T, rows) active mask."""

    def __init__(self, name: str, params: Params, agents: list[str], model: Any, obs_shape: tuple[int, ...],
                 num_envs: int, train: bool, device: torch.device, games_to_track: int) -> None:
        cfg = params.config
        self.name, self.params, self.cfg, self.agents, self.model = name, params, cfg, agents, model
        self.num_envs, self.rows, self.device = num_envs, num_envs * len(agents), device
        self.use_masks = bool(cfg.use_action_masks)
        self.tracker = AgentEpisodes(self.rows, games_to_track, device)
        self.storage = self.active = self.agent = None
        self.last_values: torch.Tensor | None = None
        # an RNN policy: the states entering the next step of each row, and the rows whose episode starts there
        self.states: tuple[torch.Tensor, ...] = model.initial_state(self.rows, device)
        self.resets = torch.ones(self.rows, dtype=torch.bool, device=device)
        if train:
            dist = model.dist
            self.storage = RolloutStorage(cfg.horizon_length, self.rows, tuple(obs_shape), torch.float32,
                                          dist.action_shape, dist.action_dtype, dist.param_size, 1, device,
                                          mask_size=dist.param_size if self.use_masks else 0,
                                          state_shapes=tuple(tuple(s.shape) for s in self.states))
            self.active = torch.zeros((cfg.horizon_length, self.rows), dtype=torch.bool, device=device)
            self.agent = MaskedPPOAgent(model, cfg, device, active=self.active)  # learns from the active steps

    def end_rollout(self, views: dict[str, Any]) -> None:
        """After a rollout, when this policy trains: the values of its rows' next observations (the returns
        bootstrap from them)."""
        if self.agent is not None:
            with torch.no_grad():
                self.last_values = self.model.value(self.gather(views)[0], self.states or None)

    def advance(self, states: tuple[torch.Tensor, ...] | None) -> None:
        """An RNN policy: the states after this step, for every row (the RNN runs over every step of a row, the
        inactive ones too, as the update's sequences do)."""
        if self.states:
            self.states = tuple(states)

    def start_episodes(self, started: torch.Tensor) -> None:
        """An RNN policy: the rows of the envs that start an episode (``started`` (E,) bool) begin from zero
        states, marked as resets."""
        if not self.states:
            return
        rows = started.repeat(len(self.agents))
        self.resets = rows
        if self.cfg.zero_rnn_on_done:
            self.states = tuple(torch.where(rows.view(1, -1, 1), torch.zeros_like(s), s) for s in self.states)

    def gather(self, views: dict[str, Any]) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | None]:
        """(obs (R, D), active (R,), masks (R, n) or None) of this policy's rows from the env's views."""
        obs = np.concatenate([views[a].obs for a in self.agents])
        active = np.concatenate([views[a].active for a in self.agents])
        masks = None
        if self.use_masks:
            masks = torch.as_tensor(np.concatenate([views[a].mask for a in self.agents]), device=self.device)
        return (torch.as_tensor(obs, device=self.device), torch.as_tensor(active, device=self.device), masks)

    def put(self, actions: dict[str, np.ndarray], env_actions: np.ndarray, owned: torch.Tensor | None) -> None:
        """The policy's (R, ...) env actions into ``actions`` (``{agent: (E, ...)}``): all of them, or with
        ``owned`` (R,) only the rows it plays (the other policies of a listed agent fill the rest)."""
        e = self.num_envs
        if owned is None:
            actions.update({a: env_actions[k * e:(k + 1) * e] for k, a in enumerate(self.agents)})
            return
        own = owned.cpu().numpy()
        for k, a in enumerate(self.agents):
            mine, rows = env_actions[k * e:(k + 1) * e], own[k * e:(k + 1) * e]
            if a not in actions:
                actions[a] = mine.copy()
            else:
                actions[a][rows] = mine[rows]

    def outcome(self, per_agent: dict[str, np.ndarray]) -> torch.Tensor:
        """A step's ``{agent: (E,)}`` field as this policy's (R,) tensor."""
        return torch.as_tensor(np.concatenate([per_agent[a] for a in self.agents]), device=self.device)


class PolicyAgents:
    """The trained policies' agents as one object: state_dict, lr scaling (divergence rollback)."""

    def __init__(self, learners: list[PolicyLearner]) -> None:
        self.agents = {lr.name: lr.agent for lr in learners if lr.agent is not None}

    @property
    def lr(self) -> float:
        return next(iter(self.agents.values())).lr if self.agents else 0.0

    def scale_lr(self, factor: float) -> None:
        for agent in self.agents.values():
            agent.scale_lr(factor)

    def state_dict(self) -> dict:
        return {name: agent.state_dict() for name, agent in self.agents.items()}

    def load_state_dict(self, state: dict) -> None:
        missing = [name for name in self.agents if name not in state]
        if missing:
                raise CheckpointError(f"checkpoint has no optimizer state for policy '{missing[0]}' "
                                  f"(it has: {', '.join(state) or 'none'})")
        for name, agent in self.agents.items():
            agent.load_state_dict(state[name])
