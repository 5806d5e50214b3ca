"""PettingZoo environments, many stepped as one vector, agent by agent (``env_name: pettingzoo``).

``env_config: {env: mpe.simple_tag_v3, kwargs: {...}}`` names a PettingZoo env module; the name
is resolved by :func:`resolve_env_module` (``pettingzoo.<name>``, then the MPE envs' own package
``mpe2`` for ``mpe.*``, then ``<name>`` as a module path of its own). The module's
``parallel_env`` is used when it has one (ParallelEnv natively); otherwise its AEC ``env`` goes
through PettingZoo's ``aec_to_parallel`` when its metadata says ``is_parallelizable``, and
turn-based games (PettingZoo classic: connect_four, tictactoe) are stepped one move per vector
step: the agent whose turn it is acts, the others wait.

Layout, for ``E = num_envs`` envs and the env's ``possible_agents``: every per-agent array has E
rows, one per env. :class:`AgentObs` per agent: ``obs`` (E, D) float32 (the observation flattened;
zeros where the agent is not in the env), ``active`` (E,) bool (the agent acts this step: it is in
the env and, turn-based, it is its turn) and ``mask`` (E, n) bool (from the observation's
``action_mask`` when the env gives one; all True where the agent is not active, so a policy
never sees an empty mask). :meth:`PettingZooVecEnv.step` takes ``{agent: actions (E, ...)}``
(rows of inactive agents are ignored) and returns per agent ``reward``, ``terminated`` and
``truncated`` (E,) -- an agent's own end, flagged once, at the step it happens -- and
``final_obs`` (E, D), its last observation there. An env whose agents are all gone is reset in
the same step (same-step auto-reset, as :mod:`rlchain.envs.vecenv`); ``started`` (E,) says which envs did so.
An env may name the policy each agent plays in its current episode (an ``episode_policies`` dict, read by
:meth:`PettingZooVecEnv.named_policies`; :mod:`rlchain.models.seats`). Agents that finish early or
appear later are simply inactive on those rows: the trainer masks them out, never pads them.
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from rlchain.config.errors import ConfigError

KEY = "params.config.env_config.env"


@dataclass
class AgentObs:
    """One agent's view of every env (see the module docstring for shapes)."""

    obs: np.ndarray
    active: np.ndarray
    mask: np.ndarray | None = None


@dataclass
class AgentsStep:
    """What one vector step returns: next observations and each agent's outcome of the step."""

    obs: dict[str, AgentObs]
    reward: dict[str, np.ndarray]
    terminated: dict[str, np.ndarray]
    truncated: dict[str, np.ndarray]
    final_obs: dict[str, np.ndarray]
    started: np.ndarray
    """(E,) bool: the env ended its episode at this step and was reset (``obs`` is a new episode's first)."""


def known_env_names() -> frozenset[str]:
    """The env names PettingZoo and mpe2 list, in the forms ``env_config.env`` takes (``classic.connect_four_v3``,
    ``pettingzoo.classic.connect_four_v3``, ``mpe.simple_spread_v3``, ``mpe2.simple_spread_v3``), read from their
    registries (PettingZoo's ``aec_registry``, else ``pettingzoo.utils.all_modules``; mpe2's ``all_modules``):
    only those packages' own modules are imported, never a module the name gives. Empty when neither is installed."""
    names: set[str] = set()
    try:  # optional: pettingzoo
        import pettingzoo
    except ImportError:
        return frozenset()
    registry = getattr(pettingzoo, "aec_registry", None)
    if registry is not None:  # ids 'classic/connect_four-v3'
        ids = [re.sub(r"-v(\d+)$", r"_v\1", key) for key in registry]
    else:  # before PettingZoo's registry: 'classic/connect_four_v3'
        try:
            from pettingzoo.utils.all_modules import all_environments
        except ImportError:
            all_environments = {}
        ids = list(all_environments)
    try:  # optional: mpe2 (the MPE envs left PettingZoo in 1.25)
        from mpe2.all_modules import mpe_environments
    except ImportError:
        mpe_environments = {}
    for key in ids:
        dotted = key.replace("/", ".")
        names.update((dotted, f"pettingzoo.{dotted}"))
    for key in mpe_environments:  # 'mpe/simple_spread_v3'
        env = key.split("/", 1)[-1]
        names.update((f"mpe.{env}", f"mpe2.{env}"))
    return frozenset(names)


def resolve_env_module(name: str) -> Any:
    """The module of the PettingZoo env ``name`` (``mpe.simple_tag_v3``, ``classic.connect_four_v3``,
    ``butterfly.pistonball_v6`` or a full module path such as ``mpe2.simple_spread_v3``).

    Tried in order: ``pettingzoo.<name>``; for ``mpe.<env>``, ``mpe2.<env>`` (the MPE envs left
    PettingZoo for the mpe2 package in PettingZoo 1.25); ``<name>`` itself, unless PettingZoo or mpe2 list
    the name (:func:`known_env_names`: a listed env is only ever their module). A ConfigError lists
    what was tried when none imports.
    """
    if not isinstance(name, str) or not name:
        raise ConfigError("", KEY, "required: a PettingZoo env such as mpe.simple_spread_v3 or "
                                   "classic.connect_four_v3")
    candidates = [f"pettingzoo.{name}"]
    if name.startswith("mpe."):
        candidates.append("mpe2." + name[len("mpe."):])
    if name not in known_env_names() or name.startswith(("pettingzoo.", "mpe2.")):
        candidates.append(name)
    problems = []
    for module_name in candidates:
        try:
            module = importlib.import_module(module_name)
        except ImportError as exc:  # includes pettingzoo.mpe's "moved to mpe2" ImportError
            problems.append(f"{module_name} ({' '.join(str(exc).split())[:80]})")
            continue
        if hasattr(module, "parallel_env") or hasattr(module, "env"):
            return module
        problems.append(f"{module_name} (no parallel_env or env)")
    raise ConfigError("", KEY, f"cannot find PettingZoo env '{name}': tried {'; '.join(problems)} "
                               f"(pip install -e '.[pettingzoo]')")


def env_maker(name: str, kwargs: dict | None = None, render: bool = False) -> tuple[Callable[[], Any], bool]:
    """(a function that builds one env, whether it is stepped turn by turn) for the env ``name``."""
    module = resolve_env_module(name)
    kwargs = dict(kwargs or {})
    if render:
        kwargs["render_mode"] = "human"
    if hasattr(module, "parallel_env"):
        return (lambda: module.parallel_env(**kwargs)), False
    probe = module.env(**kwargs)
    parallelizable = bool(getattr(probe, "metadata", {}).get("is_parallelizable", False))
    probe.close()
    if parallelizable:
        from pettingzoo.utils.conversions import aec_to_parallel
        return (lambda: aec_to_parallel(module.env(**kwargs))), False
    return (lambda: module.env(**kwargs)), True


def flat_space(space: gym.Space) -> tuple[gym.spaces.Box, int]:
    """(the flat float32 observation Box, the action mask size) of one agent's observation space;
    a Dict with ``observation`` and ``action_mask`` (PettingZoo classic) gives the mask size."""
    mask = 0
    if isinstance(space, gym.spaces.Dict) and "observation" in space.spaces:
        if "action_mask" in space.spaces:
            mask = int(np.prod(space["action_mask"].shape))
        space = space["observation"]
    dim = int(gym.spaces.flatdim(space))
    return gym.spaces.Box(-np.inf, np.inf, (dim,), np.float32), mask


class PettingZooVecEnv:
    """``num_envs`` PettingZoo envs (built by ``make``) stepped together; see the module docstring."""

    is_pettingzoo = True

    def __init__(self, make: Callable[[], Any], num_envs: int, seed: int | None = None,
                 turn_based: bool = False) -> None:
        self.envs = [make() for _ in range(num_envs)]
        self.num_envs = num_envs
        self.turn_based = turn_based
        first = self.envs[0]
        self.agent_ids: list[str] = list(first.possible_agents)
        self._raw_obs_spaces = {a: first.observation_space(a) for a in self.agent_ids}
        self.observation_spaces: dict[str, gym.spaces.Box] = {}
        self.mask_sizes: dict[str, int] = {}
        for a, space in self._raw_obs_spaces.items():
            self.observation_spaces[a], self.mask_sizes[a] = flat_space(space)
        self.action_spaces: dict[str, gym.Space] = {a: first.action_space(a) for a in self.agent_ids}
        self._seed = seed
        self._done: list[set[str]] = [set() for _ in range(num_envs)]
        self._last: list[dict[str, Any]] = [{} for _ in range(num_envs)]  # parallel: latest obs per agent
        self._games = 0  # env episodes finished since the last pop_games()

    # ----- reset / step ---------------------------------------------------------------------
    def reset(self, seed: int | None = None) -> dict[str, AgentObs]:
        """Reset every env (env i with ``seed + i``); the first observations."""
        if seed is None:
            seed, self._seed = self._seed, None
        for i in range(self.num_envs):
            self._reset_one(i, None if seed is None else seed + i)
        return self._observe_all()

    def step(self, actions: dict[str, np.ndarray]) -> AgentsStep:
        """One move in every env: each active agent's row of ``actions``; envs that end are reset."""
        e = self.num_envs
        reward = {a: np.zeros(e, np.float32) for a in self.agent_ids}
        term = {a: np.zeros(e, bool) for a in self.agent_ids}
        trunc = {a: np.zeros(e, bool) for a in self.agent_ids}
        final = {a: np.zeros((e, *self.observation_spaces[a].shape), np.float32) for a in self.agent_ids}
        started = np.zeros(e, bool)
        for i in range(e):
            outcome = self._step_turn(i, actions) if self.turn_based else self._step_parallel(i, actions)
            for agent, (r, te, tr, last) in outcome.items():
                reward[agent][i] += r
                term[agent][i], trunc[agent][i] = te, tr and not te
                if last is not None:
                    final[agent][i] = last
            if self._env_over(i):
                for agent in self._alive(i):  # gone without an end of its own: cut (truncated) here
                    if agent not in self._done[i]:
                        trunc[agent][i] = not term[agent][i]
                self._reset_one(i, None)
                self._games += 1
                started[i] = True
        return AgentsStep(self._observe_all(), reward, term, trunc, final, started)

    def _step_parallel(self, i: int, actions: dict[str, np.ndarray]) -> dict[str, tuple]:
        env = self.envs[i]
        acting = {a: _env_action(actions[a][i], self.action_spaces[a]) for a in env.agents if a in actions}
        obs, rewards, terms, truncs, _ = env.step(acting)
        self._last[i] = {a: o for a, o in obs.items()}
        out = {}
        for agent in set(rewards) | set(terms) | set(truncs):
            if agent not in self.observation_spaces:
                continue
            te, tr = bool(terms.get(agent, False)), bool(truncs.get(agent, False))
            if te or tr:
                self._done[i].add(agent)
            last = self._flat(agent, obs[agent])[0] if agent in obs else None
            out[agent] = (float(rewards.get(agent, 0.0)), te, tr, last)
        return out

    def _step_turn(self, i: int, actions: dict[str, np.ndarray]) -> dict[str, tuple]:
        env = self.envs[i]
        mover = env.agent_selection
        env.step(_env_action(actions[mover][i], self.action_spaces[mover]))
        out = {}
        for agent in self.agent_ids:
            r = float(env.rewards.get(agent, 0.0))
            te, tr = bool(env.terminations.get(agent, False)), bool(env.truncations.get(agent, False))
            newly = (te or tr) and agent not in self._done[i]
            if newly:
                self._done[i].add(agent)
            if r or newly:
                last = self._flat(agent, env.observe(agent))[0] if newly else None
                out[agent] = (r, te and newly, tr and newly, last)
        while env.agents and (env.terminations.get(env.agent_selection) or
                              env.truncations.get(env.agent_selection)):
            env.step(None)  # PettingZoo's "dead step": a finished agent leaves the env
        return out

    def _env_over(self, i: int) -> bool:
        env = self.envs[i]
        return not env.agents or all(a in self._done[i] for a in env.agents)

    def _alive(self, i: int) -> list[str]:
        return [a for a in self.envs[i].agents if a in self.observation_spaces]

    def _reset_one(self, i: int, seed: int | None) -> None:
        env = self.envs[i]
        out = env.reset(seed=seed) if seed is not None else env.reset()
        self._done[i] = set()
        if not self.turn_based:
            self._last[i] = dict(out[0] if isinstance(out, tuple) else out)

    # ----- observations ---------------------------------------------------------------------
    def _observe_all(self) -> dict[str, AgentObs]:
        e = self.num_envs
        views = {}
        for agent in self.agent_ids:
            size = self.mask_sizes[agent]
            views[agent] = AgentObs(np.zeros((e, *self.observation_spaces[agent].shape), np.float32),
                                    np.zeros(e, bool), np.ones((e, size), bool) if size else None)
        for i, env in enumerate(self.envs):
            for agent in self._alive(i):
                if agent in self._done[i]:
                    continue
                if self.turn_based:
                    raw, acting = env.observe(agent), agent == env.agent_selection
                elif agent in self._last[i]:
                    raw, acting = self._last[i][agent], True
                else:
                    continue
                view = views[agent]
                view.obs[i], mask = self._flat(agent, raw)
                view.active[i] = acting
                if acting and mask is not None and view.mask is not None:
                    view.mask[i] = mask
        return views

    def _flat(self, agent: str, raw: Any) -> tuple[np.ndarray, np.ndarray | None]:
        """An agent's observation as its flat float32 row (gymnasium's ``flatten`` of its space: a Discrete
        one-hot) and its action mask, if the observation carries one."""
        mask = None
        space = self._raw_obs_spaces[agent]
        if isinstance(raw, dict) and "observation" in raw:
            mask = np.asarray(raw["action_mask"], bool).reshape(-1) if "action_mask" in raw else None
            raw = raw["observation"]
            if isinstance(space, gym.spaces.Dict) and "observation" in space.spaces:
                space = space["observation"]
        if isinstance(space, gym.spaces.Box):
            return np.asarray(raw, np.float32).reshape(-1), mask
        return np.asarray(gym.spaces.flatten(space, raw), np.float32).reshape(-1), mask

    def named_policies(self, i: int) -> dict[str, str] | None:
        """agent -> policy name for env ``i``'s current episode where the env names them (its
        ``episode_policies``), else None."""
        return getattr(self.envs[i], "episode_policies", None)

    def pop_games(self) -> int:
        """Env episodes (games) finished since the last call."""
        games, self._games = self._games, 0
        return games

    def render(self) -> Any:
        return self.envs[0].render()

    def close(self) -> None:
        for env in self.envs:
            env.close()


def _env_action(action: Any, space: gym.Space) -> Any:
    """One agent's action as its env takes it: an int for Discrete, an array otherwise."""
    if isinstance(space, gym.spaces.Discrete):
        return int(np.asarray(action).reshape(-1)[0])
    return np.asarray(action, dtype=space.dtype).reshape(space.shape)


def pettingzoo_env(num_envs: int, seed: int | None = None, env: str = "", kwargs: dict | None = None,
                   render: bool = False) -> PettingZooVecEnv:
    """The ``pettingzoo`` entry of the env registry: ``env_config: {env: <name>, kwargs: {...}}``."""
    make, turn_based = env_maker(env, kwargs, render)
    return PettingZooVecEnv(make, num_envs, seed, turn_based)
