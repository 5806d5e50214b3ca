"""Which policy plays each agent of each env, episode by episode (``multi_agent.policy_mapping`` with lists).

An agent whose glob names one policy plays it for the whole run. An agent whose glob names a list of policies
plays one of them per episode of each env, chosen at the episode's start: the env's choice where the env names
one (``named_policies(i)`` of rlchain's PettingZoo backend: the RLlib face's ``policy_mapping_fn``), else drawn
uniformly at random from the run's seeded generator. Each policy of the list has a row for that agent in every
env (a slot): :meth:`Seats.owned` says which of a policy's rows it plays in the current episodes, and the
multi-policy algorithm and the play loop leave the others out (no action of that policy reaches the env, no
reward, end or step of it is counted).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from rlchain.config.errors import ConfigError
from rlchain.config.multi_agent import KEY, PolicyMapping
from rlchain.config.params import Params


class Seats:
    """The current policy of every drawn agent (one whose ``candidates`` list several) in each of ``num_envs``
    envs; agents with one candidate are not tracked (their policy plays all their rows)."""

    def __init__(self, candidates: dict[str, list[str]], num_envs: int, seed: int | None = None,
                 source: str = "") -> None:
        self.candidates = {agent: list(names) for agent, names in candidates.items()}
        self.num_envs, self.source = num_envs, source
        self.drawn = [agent for agent, names in self.candidates.items() if len(names) > 1]
        self.dynamic = bool(self.drawn)
        self.choice = {agent: np.zeros(num_envs, np.int64) for agent in self.drawn}  # index into candidates
        self.rng = np.random.default_rng(seed)
        self._owned: dict[tuple[str, tuple[str, ...]], np.ndarray | None] = {}

    def owned(self, policy: str, agents: list[str]) -> np.ndarray | None:
        """(len(agents) * num_envs,) bool, agent-major (row ``k * E + e`` is agent k of env e): the rows of
        ``policy``'s slots it plays in the current episodes; None when it plays every one of them."""
        key = (policy, tuple(agents))
        if key not in self._owned:
            if not any(agent in self.choice for agent in agents):
                self._owned[key] = None
            else:
                self._owned[key] = np.concatenate([
                    self.choice[a] == self.candidates[a].index(policy) if a in self.choice
                    else np.ones(self.num_envs, bool) for a in agents])
        return self._owned[key]

    def policy_of(self, agent: str, env: int) -> str:
        """The policy that plays ``agent`` in env ``env``'s current episode."""
        names = self.candidates[agent]
        return names[int(self.choice[agent][env])] if agent in self.choice else names[0]

    def draw(self, envs: np.ndarray, named: Callable[[int], dict[str, str] | None] | None = None) -> None:
        """New episodes start in ``envs`` (env indices): each drawn agent's policy there, the env's choice
        (``named(i)``: agent -> policy, or None) where it names one, else uniformly at random."""
        if not self.dynamic or len(envs) == 0:
            return
        envs = np.asarray(envs, np.int64)
        for agent in self.drawn:
            self.choice[agent][envs] = self.rng.integers(len(self.candidates[agent]), size=len(envs))
        if named is not None:
            for i in envs.tolist():
                for agent, policy in (named(i) or {}).items():
                    if agent in self.choice:
                        self.choice[agent][i] = self._index(agent, policy)
        self._owned.clear()

    def _index(self, agent: str, policy: str) -> int:
        names = self.candidates[agent]
        if policy not in names:
            raise ConfigError(self.source, f"{KEY}.policy_mapping", f"the env chose policy '{policy}' for agent "
                                                                     f"'{agent}', which may play only "
                                                                     f"{', '.join(names)}")
        return names.index(policy)

    def state_dict(self) -> dict[str, Any]:
        """The generator's state (the current choices are drawn again when the envs reset)."""
        return {"rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if state.get("rng") is not None:
            self.rng.bit_generator.state = state["rng"]


def seats_of(params: Params, env: Any, seed: int | None) -> Seats:
    """The :class:`Seats` of the env's agents under ``multi_agent.policy_mapping``."""
    mapping = PolicyMapping(params.config.multi_agent.policy_mapping, list(params.policies), params.source)
    return Seats({agent: mapping.candidates(agent) for agent in env.agent_ids}, env.num_envs, seed, params.source)
