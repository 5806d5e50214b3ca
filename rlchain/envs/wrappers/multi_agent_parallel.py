"""An RLlib-style multi-agent env (``reset() -> (obs, infos)``, ``step(action_dict) -> (obs, rewards,
terminateds, truncateds, infos)``, dicts keyed by agent id, ``"__all__"`` ending the episode) seen as
PettingZoo's ParallelEnv, which rlchain's PettingZoo backend steps (:mod:`rlchain.envs.backends.pettingzoo_env`).

An agent acts at a step when the last ``obs`` dict holds it (turn-based games send only the mover's); it leaves
when its own ``terminateds`` / ``truncateds`` entry is True, and may appear mid-episode by getting an observation.
Agent ids are shown as strings. Finished episodes go to an :class:`EpisodeLog` as RLlib reports them. With a
``choose`` function (agent ids -> {agent: policy}, asked at every reset), the view names each agent's policy for
the episode (``episode_policies``, which rlchain's PettingZoo backend hands to :mod:`rlchain.models.seats`) and
logs it with the episode. This module reads the env by duck typing only (the RLlib face,
:mod:`rlchain.rllib.multi_agent`, builds on it).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any

import gymnasium as gym

from rlchain.config.errors import ConfigError

ALL = "__all__"
"""RLlib's key in ``terminateds`` / ``truncateds`` that ends the episode for every agent."""


def space_of(spaces: dict | None, space: gym.Space | None, agent_id: Any) -> gym.Space:
    """One agent's space: from per-agent ``spaces``, else ``space`` (a Dict by agent id, or shared by all)."""
    if spaces is not None:
        return spaces[agent_id]
    if isinstance(space, gym.spaces.Dict) and agent_id in space.spaces:
        return space[agent_id]
    return space


class EpisodeLog:
    """Finished episodes of every env copy, as RLlib reports multi-agent ones: the return summed over agents,
    the length in env steps, and each agent's own return."""

    def __init__(self, window: int = 100) -> None:
        self.returns: deque = deque(maxlen=window)
        self.lengths: deque = deque(maxlen=window)
        self.agent_returns: dict[str, deque] = {}
        self.window = window
        self.finished = 0

    def add(self, total: float, length: int, per_agent: dict[str, float],
            modules: dict[str, str] | None = None) -> None:
        """One finished episode; ``modules``: the policy each agent played in it, where it was chosen for it."""
        self.returns.append(total)
        self.lengths.append(length)
        for agent, value in per_agent.items():
            self.agent_returns.setdefault(agent, deque(maxlen=self.window)).append(value)
        self.finished += 1


class ParallelView:
    """One RLlib-style multi-agent env as PettingZoo's ParallelEnv (agent ids as strings); see the module
    docstring."""

    metadata = {"name": "rllib_multi_agent", "is_parallelizable": True}

    def __init__(self, env: Any, agent_ids: list[Any], log: EpisodeLog | None = None,
                 choose: Callable[[list[Any]], dict[Any, str]] | None = None) -> None:
        self.env = env
        self._ids = {str(a): a for a in agent_ids}
        if len(self._ids) != len(agent_ids):
            raise ConfigError("AlgorithmConfig.environment()", "env", f"agent ids {agent_ids!r} are not distinct "
                                                                      f"as strings")
        self.possible_agents = list(self._ids)
        self.agents: list[str] = []
        self._acting: set[str] = set()
        self._log = log
        self._choose = choose
        self.episode_policies: dict[str, str] | None = None  # agent -> its policy this episode (with choose)
        self._returns: dict[str, float] = {}
        self._length = 0

    def observation_space(self, agent: str) -> gym.Space:
        return self.env.get_observation_space(self._ids[agent]) if hasattr(self.env, "get_observation_space") \
            else space_of(getattr(self.env, "observation_spaces", None), self.env.observation_space, self._ids[agent])

    def action_space(self, agent: str) -> gym.Space:
        return self.env.get_action_space(self._ids[agent]) if hasattr(self.env, "get_action_space") \
            else space_of(getattr(self.env, "action_spaces", None), self.env.action_space, self._ids[agent])

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        out = self.env.reset(seed=seed, options=options)
        obs, infos = out if isinstance(out, tuple) else (out, {})
        obs = self._keyed(obs)
        self.agents = list(obs)
        self._acting = set(obs)
        self._returns, self._length = {}, 0
        if self._choose is not None:
            self.episode_policies = self._keyed(self._choose(list(self._ids.values())))
        return obs, self._keyed(infos or {})

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        sent = {self._ids[a]: act for a, act in actions.items() if a in self._acting}
        obs, rewards, terms, truncs, infos = self.env.step(sent)
        obs, rewards = self._keyed(obs), self._keyed(rewards)
        all_term, all_trunc = bool(terms.get(ALL, False)), bool(truncs.get(ALL, False))
        terms = {a: bool(v) for a, v in self._keyed(terms).items()}
        truncs = {a: bool(v) for a, v in self._keyed(truncs).items()}
        alive = [a for a in dict.fromkeys([*self.agents, *obs])]
        if all_term or all_trunc:  # the episode is over for every agent still in it
            for agent in alive:
                if not (terms.get(agent) or truncs.get(agent)):
                    terms[agent], truncs[agent] = all_term, all_trunc and not all_term
        done = {a for a in alive if terms.get(a) or truncs.get(a)}
        self.agents = [a for a in alive if a not in done]
        self._acting = {a for a in obs if a not in done}
        self._length += 1
        for agent, reward in rewards.items():
            self._returns[agent] = self._returns.get(agent, 0.0) + float(reward)
        if not self.agents and self._log is not None:
            self._log.add(sum(self._returns.values()), self._length, dict(self._returns), self.episode_policies)
        return obs, rewards, terms, truncs, self._keyed(infos or {})

    def _keyed(self, values: dict) -> dict:
        return {str(a): v for a, v in values.items() if a != ALL}

    def render(self) -> Any:
        return self.env.render()

    def close(self) -> None:
        close = getattr(self.env, "close", None)
        if callable(close):
            close()


def agent_ids_of(env: Any) -> list[Any]:
    """Every agent id the env may have: ``possible_agents``, else ``agents``, else the ids of its per-agent
    spaces, else those of its first observations."""
    for ids in (getattr(env, "possible_agents", None), getattr(env, "agents", None),
                list(getattr(env, "observation_spaces", None) or {})):
        if ids:
            return list(ids)
    space = getattr(env, "observation_space", None)
    if isinstance(space, gym.spaces.Dict):
        return list(space.spaces)
    obs = env.reset()[0]
    return [a for a in obs if a != ALL]
