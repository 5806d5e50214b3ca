"""Per-policy pieces of multi-policy PPO: the models (one per policy), each policy's rows of the
PettingZoo env, its learner (agent, rollout storage, active mask) and its episode statistics."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.algos.core.storage import RolloutStorage
from rlchain.algos.multi_policy.masked import MaskedPPOAgent
from rlchain.config.errors import ConfigError
from rlchain.config.multi_agent import KEY, PolicyMapping
from rlchain.config.schema import Params
from rlchain.envs.spec import env_spec
from rlchain.training.episodes import EpisodeTracker


@dataclass
class PolicyView:
    """What one policy sees of the env: its agents' (equal) spaces; ``value_size`` as VecEnvs have."""

    observation_space: gym.Space
    action_space: gym.Space
    mask_size: int
    value_size: int = 1


def policy_agents(params: Params, env: Any) -> dict[str, list[str]]:
    """policy name -> the env's agent ids it plays (policy_mapping; an unmapped agent is an error)."""
    ma = params.config.multi_agent
    mapping = PolicyMapping(ma.policy_mapping, list(params.policies), params.source)
    return mapping.assign(list(env.agent_ids))


def policy_view(params: Params, env: Any, name: str, agents: list[str]) -> PolicyView:
    """The spaces of the agents of ``name``; agents of one policy must share them."""
    first = agents[0]
    for other in agents[1:]:
        for what, spaces in (("observation", env.observation_spaces), ("action", env.action_spaces)):
            if spaces[other] != spaces[first]:
                raise ConfigError(params.source, f"{KEY}.policy_mapping",
                                  f"agents '{first}' and '{other}' both map to policy '{name}' but their "
                                  f"{what} spaces differ ({spaces[first]} vs {spaces[other]}); give them "
                                  f"separate policies")
    return PolicyView(env.observation_spaces[first], env.action_spaces[first], env.mask_sizes[first])


def build_policy_models(params: Params, env: Any, device: torch.device) -> torch.nn.ModuleDict:
    """One model per policy (``params.policies``), each built from its own network and model preset
    for its agents' spaces; a space the named network or model cannot take is a one-line ConfigError."""
    from rlchain.models.build import build_model

    if not env_spec(env).pettingzoo:
        raise ConfigError(params.source, KEY, "needs env_name: pettingzoo (a PettingZoo env in env_config.env); "
                                              "rl_games-style multi-agent envs share one policy without it")
    models = torch.nn.ModuleDict()
    for name, agents in policy_agents(params, env).items():
        if not agents:
            continue  # a policy no agent plays (e.g. the opponent of a seat not in this env) is not built
        view = policy_view(params, env, name, agents)
        policy = params.policies[name]
        try:
            models[name] = build_model(policy, view, device)
        except (ConfigError, ValueError, TypeError, RuntimeError) as exc:
            detail = getattr(exc, "message", None) or " ".join(str(exc).split())
            raise ConfigError(params.source, f"{KEY}.policies.{name}",
                              f"network '{_network_name(policy.network)}' / model '{policy.model.name}' do "
                              f"not fit agents {agents} (observations {view.observation_space}, actions "
                              f"{view.action_space}): {detail}") from None
    return models


def _network_name(network: Any) -> str:
    return network.name if hasattr(network, "name") else (network or {}).get("name", "actor_critic")


class AgentEpisodes(EpisodeTracker):
    """Episode returns per agent row; an episode's length counts the agent's own (active) steps."""

    def agent_step(self, rewards: torch.Tensor, dones: torch.Tensor, active: torch.Tensor) -> None:
        """rewards (R,), dones (R,) bool (the agent ended at this step), active (R,) bool (it acted)."""
        self.returns += rewards
        self.lengths += active.long()
        if dones.any():
            idx = dones.nonzero().squeeze(-1)
            self.finished_returns.extend(self.returns[idx].tolist())
            self.finished_lengths.extend(self.lengths[idx].tolist())
            self.games += int(idx.numel())
            self.returns[idx] = 0.0
            self.lengths[idx] = 0


class PolicyLearner:
    """One policy: its model, its agents' rows (agent-major: row ``k * E + e`` is agent k of env e)
    and, when it trains, a :class:`MaskedPPOAgent`, a rollout storage and the (T, rows) active mask."""

    def __init__(self, name: str, params: Params, agents: list[str], model: Any, obs_shape: tuple[int, ...],
                 num_envs: int, train: bool, device: torch.device, games_to_track: int) -> None:
        cfg = params.config
        self.name, self.params, self.cfg, self.agents, self.model = name, params, cfg, agents, model
        self.num_envs, self.rows, self.device = num_envs, num_envs * len(agents), device
        self.use_masks = bool(cfg.use_action_masks)
        self.agent = MaskedPPOAgent(model, cfg, device) if train else None
        self.tracker = AgentEpisodes(self.rows, games_to_track, device)
        self.storage = self.active = None
        self.last_values: torch.Tensor | None = None
        self.pool: Any = None  # a frozen self-play snapshot: past snapshots env by env (snapshots.py)
        if train:
            dist = model.dist
            self.storage = RolloutStorage(cfg.horizon_length, self.rows, tuple(obs_shape), torch.float32,
                                          dist.action_shape, dist.action_dtype, dist.param_size, 1, device,
                                          mask_size=dist.param_size if self.use_masks else 0)
            self.active = torch.zeros((cfg.horizon_length, self.rows), dtype=torch.bool, device=device)

    def gather(self, views: dict[str, Any]) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | None]:
        """(obs (R, D), active (R,), masks (R, n) or None) of this policy's rows from the env's views."""
        obs = np.concatenate([views[a].obs for a in self.agents])
        active = np.concatenate([views[a].active for a in self.agents])
        masks = None
        if self.use_masks:
            masks = torch.as_tensor(np.concatenate([views[a].mask for a in self.agents]), device=self.device)
        return (torch.as_tensor(obs, device=self.device), torch.as_tensor(active, device=self.device), masks)

    def split(self, env_actions: np.ndarray) -> dict[str, np.ndarray]:
        """The policy's (R, ...) env actions as ``{agent: (E, ...)}``."""
        e = self.num_envs
        return {a: env_actions[k * e:(k + 1) * e] for k, a in enumerate(self.agents)}

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
            from rlchain.runs.checkpoint import CheckpointError
            raise CheckpointError(f"checkpoint has no optimizer state for policy '{missing[0]}' "
                                  f"(it has: {', '.join(state) or 'none'})")
        for name, agent in self.agents.items():
            agent.load_state_dict(state[name])
