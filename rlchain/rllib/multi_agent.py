"""RLlib's ``MultiAgentEnv`` trained on rlchain's multi-policy PPO.

RLlib's multi-agent API: ``reset() -> (obs, infos)`` and ``step(action_dict) -> (obs, rewards, terminateds,
truncateds, infos)``, dicts keyed by agent id, ``"__all__"`` in ``terminateds`` / ``truncateds`` ending the
episode. An agent acts at a step when the last ``obs`` dict holds it (turn-based games send only the mover's);
it leaves when its own ``terminateds`` / ``truncateds`` entry is True, and may appear mid-episode by getting an
observation. :class:`ParallelView` shows one such env as PettingZoo's ParallelEnv, which rlchain's
PettingZoo backend steps (:mod:`rlchain.envs.backends.pettingzoo_env`): steps where an agent is absent or waits
are masked out of its policy's returns and loss (:mod:`rlchain.algos.multi_policy.masked`), and rewards an agent
gets while waiting are summed into its next step.

``.multi_agent(policies=..., policy_mapping_fn=..., policies_to_train=...)``: each policy gets its own rlchain
model and optimizer; ``policy_mapping_fn(agent_id, episode)`` is asked once per agent id (rlchain maps an agent
id to one policy for the whole run: a mapping that changes by episode is a one-line error).
"""

from __future__ import annotations

import copy
import glob
import itertools
from collections import deque
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from rlchain import env_configurations
from rlchain.config.errors import ConfigError

_COUNTER = itertools.count(1)
ALL = "__all__"
ENV_STATE = "state"
"""RLlib's key of a global state in an agent's observation dict (RLlib's grouped-agents examples use it)."""


class MultiAgentEnv(gym.Env):
    """RLlib's multi-agent env base: ``possible_agents``, ``agents``, per-agent ``observation_spaces`` /
    ``action_spaces`` (or one ``observation_space`` / ``action_space``, a Dict by agent id or shared by all)."""

    observation_spaces: dict | None = None
    action_spaces: dict | None = None
    agents: list = []
    possible_agents: list = []
    observation_space: gym.Space | None = None
    action_space: gym.Space | None = None

    def __init__(self) -> None:
        super().__init__()
        if not hasattr(self, "_agent_ids"):
            self._agent_ids = set()
        if not self.agents:
            self.agents = list(self._agent_ids)
        if not self.possible_agents:
            self.possible_agents = list(self.agents)

    def get_observation_space(self, agent_id: Any) -> gym.Space:
        return _space_of(self.observation_spaces, self.observation_space, agent_id)

    def get_action_space(self, agent_id: Any) -> gym.Space:
        return _space_of(self.action_spaces, self.action_space, agent_id)

    @property
    def num_agents(self) -> int:
        return len(self.agents)

    @property
    def max_num_agents(self) -> int:
        return len(self.possible_agents)

    def get_agent_ids(self) -> set:
        return set(self.possible_agents or self._agent_ids)

    def render(self) -> Any:
        return None


def _space_of(spaces: dict | None, space: gym.Space | None, agent_id: Any) -> gym.Space:
    if spaces is not None:
        return spaces[agent_id]
    if isinstance(space, gym.spaces.Dict) and agent_id in space.spaces:
        return space[agent_id]
    return space


def make_multi_agent(env_name_or_creator: Any) -> type[MultiAgentEnv]:
    """RLlib's helper: a MultiAgentEnv class of ``config["num_agents"]`` (default 1) independent copies of a
    single-agent env (a gymnasium id, or a creator taking the env config), agents ``0 .. n-1``."""

    class MultiEnv(MultiAgentEnv):
        def __init__(self, config: dict | None = None) -> None:
            super().__init__()
            config = copy.copy(dict(config or {}))
            num = int(config.pop("num_agents", 1))
            if isinstance(env_name_or_creator, str):
                self.envs = [gym.make(env_name_or_creator) for _ in range(num)]
            else:
                self.envs = [env_name_or_creator(config) for _ in range(num)]
            self.observation_spaces = {i: env.observation_space for i, env in enumerate(self.envs)}
            self.action_spaces = {i: env.action_space for i, env in enumerate(self.envs)}
            self.agents = list(range(num))
            self.possible_agents = list(self.agents)
            self.observation_space, self.action_space = self.envs[0].observation_space, self.envs[0].action_space
            self.ended: set = set()

        def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
            self.ended = set()
            obs, infos = {}, {}
            for i, env in enumerate(self.envs):
                obs[i], infos[i] = env.reset(seed=None if seed is None else seed + i, options=options)
            return obs, infos

        def step(self, action_dict: dict) -> tuple[dict, dict, dict, dict, dict]:
            obs, rew, term, trunc, info = {}, {}, {}, {}, {}
            for i, action in action_dict.items():
                obs[i], rew[i], term[i], trunc[i], info[i] = self.envs[i].step(action)
                if term[i] or trunc[i]:
                    self.ended.add(i)
            term[ALL] = len(self.ended) == len(self.envs)
            trunc[ALL] = False
            return obs, rew, term, trunc, info

        def render(self) -> Any:
            return self.envs[0].render()

    name = env_name_or_creator if isinstance(env_name_or_creator, str) else "env"
    MultiEnv.__name__ = MultiEnv.__qualname__ = f"MultiAgent_{name}".replace("-", "_")
    return MultiEnv


def is_multi_agent(env: Any) -> bool:
    """Whether an env object speaks RLlib's multi-agent API (a MultiAgentEnv, RLlib's own or the face's)."""
    return isinstance(env, MultiAgentEnv) or any(c.__name__ == "MultiAgentEnv" for c in type(env).__mro__)


class EpisodeLog:
    """Finished episodes of every env copy, as RLlib reports multi-agent ones: the return summed over agents,
    the length in env steps, and each agent's own return."""

    def __init__(self, window: int = 100) -> None:
        self.returns: deque = deque(maxlen=window)
        self.lengths: deque = deque(maxlen=window)
        self.agent_returns: dict[str, deque] = {}
        self.window = window
        self.finished = 0

    def add(self, total: float, length: int, per_agent: dict[str, float]) -> None:
        self.returns.append(total)
        self.lengths.append(length)
        for agent, value in per_agent.items():
            self.agent_returns.setdefault(agent, deque(maxlen=self.window)).append(value)
        self.finished += 1


class ParallelView:
    """One RLlib MultiAgentEnv as PettingZoo's ParallelEnv (agent ids as strings); see the module docstring."""

    metadata = {"name": "rllib_multi_agent", "is_parallelizable": True}

    def __init__(self, env: Any, agent_ids: list[Any], log: EpisodeLog | None = None) -> None:
        self.env = env
        self._ids = {str(a): a for a in agent_ids}
        if len(self._ids) != len(agent_ids):
            raise ConfigError("AlgorithmConfig.environment()", "env", f"agent ids {agent_ids!r} are not distinct "
                                                                      f"as strings")
        self.possible_agents = list(self._ids)
        self.agents: list[str] = []
        self._acting: set[str] = set()
        self._log = log
        self._returns: dict[str, float] = {}
        self._length = 0

    def observation_space(self, agent: str) -> gym.Space:
        return self.env.get_observation_space(self._ids[agent]) if hasattr(self.env, "get_observation_space") \
            else _space_of(getattr(self.env, "observation_spaces", None), self.env.observation_space, self._ids[agent])

    def action_space(self, agent: str) -> gym.Space:
        return self.env.get_action_space(self._ids[agent]) if hasattr(self.env, "get_action_space") \
            else _space_of(getattr(self.env, "action_spaces", None), self.env.action_space, self._ids[agent])

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        out = self.env.reset(seed=seed, options=options)
        obs, infos = out if isinstance(out, tuple) else (out, {})
        obs = self._keyed(obs)
        self.agents = list(obs)
        self._acting = set(obs)
        self._returns, self._length = {}, 0
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
            self._log.add(sum(self._returns.values()), self._length, dict(self._returns))
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


def register(make: Callable[[int], Any], agent_ids: list[Any], logs: list[EpisodeLog], window: int = 100) -> str:
    """A fresh env name whose builder steps ``make(0..n-1)`` (each a MultiAgentEnv) with rlchain's PettingZoo
    backend; each built vector env's finished episodes go to a new :class:`EpisodeLog` appended to ``logs`` (the
    training env's is the first, an evaluation env's the last)."""
    from rlchain.envs.backends.pettingzoo_env import PettingZooVecEnv
    name = f"rllib_multi_agent_env_{next(_COUNTER)}"

    def build(num_envs: int, seed: int | None, *, render: bool = False, **env_config: Any) -> PettingZooVecEnv:
        if env_config:
            raise ConfigError("", "params.config.env_config", "an RLlib MultiAgentEnv takes its env_config from "
                                                              "the RLlib config")
        index = itertools.count()
        log = EpisodeLog(window)
        logs.append(log)
        return PettingZooVecEnv(lambda: ParallelView(make(next(index)), agent_ids, log), num_envs, seed)

    env_configurations.register(name, {"vecenv_creator": build})
    return name


# ----- the policies ------------------------------------------------------------------------------------------------
class _Episode:
    """What a policy_mapping_fn may read of the episode it is asked in (RLlib's MultiAgentEpisode)."""

    def __init__(self, index: int) -> None:
        self.id_ = self.episode_id = f"episode_{index}"
        self.env_id = 0
        self.worker_index = 0


def policy_names(config: Any) -> tuple[list[str], dict[str, Any]]:
    """(policy ids, policy id -> its RLlib entry) of ``.multi_agent(policies=...)``: a set / list of ids or a
    dict of id -> None / PolicySpec / (cls, obs_space, act_space, config)."""
    where = f"{type(config).__name__}.multi_agent()"
    policies = config._settings.get("policies")
    if policies is None:
        return ["default_policy"], {"default_policy": None}
    if isinstance(policies, dict):
        entries = dict(policies)
    elif isinstance(policies, (set, frozenset, list, tuple)):
        entries = dict.fromkeys(policies)
    else:
        raise ConfigError(where, "policies", f"expected a set of policy ids or a dict, got {type(policies).__name__}")
    for pid, entry in entries.items():
        if not isinstance(pid, str):
            raise ConfigError(where, "policies", f"policy id {pid!r}: expected a string")
        overrides = getattr(entry, "config", None) if not isinstance(entry, (tuple, list)) else \
            (entry[3] if len(entry) > 3 else None)
        if overrides:
            raise ConfigError(where, f"policies.{pid}", "per-policy config overrides are not mapped: every policy "
                                                        "trains with the config's keys")
    return list(entries), entries


def agent_policies(config: Any, agent_ids: list[Any], names: list[str]) -> dict[Any, str]:
    """agent id -> policy id by ``policy_mapping_fn`` (asked for two episodes: it must answer the same)."""
    where = f"{type(config).__name__}.multi_agent()"
    fn = config._settings.get("policy_mapping_fn")
    if fn is None:
        if len(names) == 1:
            return dict.fromkeys(agent_ids, names[0])
        raise ConfigError(where, "policy_mapping_fn", f"required with several policies ({', '.join(names)})")
    out = {}
    for agent in agent_ids:
        answers = []
        for index in (0, 1):
            try:
                answers.append(fn(agent, _Episode(index), worker=None))
            except TypeError:
                answers.append(fn(agent, _Episode(index)))
        if answers[0] != answers[1]:
            raise ConfigError(where, "policy_mapping_fn", f"maps agent {agent!r} to {answers[0]!r} in one episode "
                              f"and {answers[1]!r} in another: rlchain maps each agent id to one policy for the run")
        if answers[0] not in names:
            raise ConfigError(where, "policy_mapping_fn", f"maps agent {agent!r} to {answers[0]!r}, not one of the "
                                                          f"policies ({', '.join(names)})")
        out[agent] = answers[0]
    return out


def trained_policies(config: Any, names: list[str]) -> list[str] | None:
    """``policies_to_train``: a collection of ids or a function (policy id, batch) -> bool; None: all."""
    value = config._settings.get("policies_to_train")
    if value is None:
        return None
    if callable(value):
        return [pid for pid in names if value(pid, None)]
    unknown = [pid for pid in value if pid not in names]
    if unknown:
        raise ConfigError(f"{type(config).__name__}.multi_agent()", "policies_to_train",
                          f"{unknown[0]!r} is not one of the policies ({', '.join(names)})")
    return list(value)


def ppo_config(config: Any, base: dict[str, Any], view: ParallelView, network_of: Callable[..., dict]
               ) -> dict[str, Any]:
    """The rlchain multi-policy PPO config: ``base`` (the single-agent translation, its keys shared by every
    policy) with a ``multi_agent`` block: each policy's network (``network_of(policy, obs_space, act_space)``)
    and model for its agents' spaces, the agent -> policy mapping, the trained policies."""
    names, _ = policy_names(config)
    agents = [view._ids[a] for a in view.possible_agents]
    mapping = agent_policies(config, agents, names)
    params = base["params"]
    policies: dict[str, Any] = {}
    for pid in names:
        mine = [str(a) for a in agents if mapping[a] == pid]
        if not mine:
            continue
        obs_space, act_space = view.observation_space(mine[0]), view.action_space(mine[0])
        continuous = isinstance(act_space, gym.spaces.Box)
        if not isinstance(act_space, (gym.spaces.Box, gym.spaces.Discrete)):
            raise ConfigError(type(config).__name__, "env", f"policy {pid!r}: {type(act_space).__name__} actions "
                                                            f"are not mapped by the face (Box or Discrete)")
        model = "continuous_a2c_logstd" if continuous else "discrete_a2c"
        policies[pid] = {"network": network_of(pid, obs_space, act_space), "model": {"name": model},
                         "config": {"clip_actions": continuous}}
    to_train = trained_policies(config, names)
    block = {"policies": policies,
             "policy_mapping": {glob.escape(str(a)): pid for a, pid in mapping.items() if pid in policies},
             "policies_to_train": None if to_train is None else [p for p in to_train if p in policies]}
    params["config"]["multi_agent"] = block
    return base


def flat_dim(space: gym.Space) -> int:
    return int(np.prod(gym.spaces.flatten_space(space).shape))


class MultiAgentRun:
    """What the face's Algorithm needs of a multi-agent env: its agents and spaces (read from a probe copy), the
    rlchain config, and RLlib's multi-agent results (episode returns summed over agents, per policy learners)."""

    def __init__(self, config: Any, probe: Any) -> None:
        if config.algo_name != "PPO":
            raise ConfigError(type(config).__name__, "env", f"a MultiAgentEnv trains under PPO only, not "
                                                            f"{config.algo_name}")
        self.agent_ids = agent_ids_of(probe)
        self.view = ParallelView(probe, self.agent_ids)
        self.names, _ = policy_names(config)
        self.mapping = agent_policies(config, self.agent_ids, self.names)
        self.spaces = {}  # policy id -> (observation space, action space) of its agents
        for agent, pid in self.mapping.items():
            self.spaces.setdefault(pid, (self.view.observation_space(str(agent)), self.view.action_space(str(agent))))
        self.trained = trained_policies(config, self.names)  # None: every policy
        self.logs: list[EpisodeLog] = []

    def rlchain_config(self, config: Any, make: Callable[[int], Any], run: dict[str, Any],
                       network_of: Callable[..., dict]) -> tuple[str, dict[str, Any]]:
        """(the registered env name, the rlchain multi-policy PPO config)."""
        from rlchain.rllib import translate
        window = int(config._settings.get("metrics_num_episodes_for_smoothing") or 100)
        env_name = register(make, self.agent_ids, self.logs, window)
        base = translate.ppo_config(config, env_name, False, run)
        return env_name, ppo_config(config, base, self.view, network_of)

    def episodes(self, log: EpisodeLog | None = None) -> dict[str, Any]:
        """RLlib's env-runner episode metrics of ``log`` (default: the training env's)."""
        log = log or (self.logs[0] if self.logs else EpisodeLog())
        nan = float("nan")
        def mean(xs: Any) -> float:
            return float(np.mean(xs)) if len(xs) else nan

        agent_returns = {a: mean(r) for a, r in log.agent_returns.items()}
        module_returns: dict[str, float] = {}
        for agent, pid in self.mapping.items():
            if str(agent) in agent_returns:
                module_returns[pid] = module_returns.get(pid, 0.0) + agent_returns[str(agent)]
        return {"episode_return_mean": mean(log.returns),
                "episode_return_max": max(log.returns) if log.returns else nan,
                "episode_return_min": min(log.returns) if log.returns else nan,
                "episode_len_mean": mean(log.lengths), "num_episodes_lifetime": log.finished,
                "agent_episode_returns_mean": {self._id(a): v for a, v in agent_returns.items()},
                "module_episode_returns_mean": module_returns}

    def _id(self, agent: str) -> Any:
        return self.view._ids.get(agent, agent)

    def learners(self, stats: dict[str, float], lr: float) -> dict[str, dict[str, float]]:
        """RLlib's ``learners/<policy>`` results (trained policies only) from rlchain's per-policy tags."""
        nan = float("nan")
        out = {}
        for pid in self.names:
            if pid not in self.spaces or (self.trained is not None and pid not in self.trained):
                continue
            tag = (lambda kind, key, pid=pid: stats.get(f"{kind}/{pid}/{key}", nan))
            out[pid] = {"policy_loss": tag("losses", "a_loss"), "vf_loss": tag("losses", "c_loss"),
                        "entropy": tag("losses", "entropy"), "mean_kl_loss": tag("info", "kl"),
                        "curr_lr": stats.get(f"info/{pid}/last_lr", lr),
                        "curr_entropy_coeff": stats.get(f"info/{pid}/entropy_coef", 0.0)}
        return out

    def evaluate(self, params: Any, models: Any, episodes: int, deterministic: bool) -> dict[str, Any]:
        """``episodes`` episodes of every policy on a fresh env (rlchain's multi-policy play loop); RLlib's
        evaluation results."""
        from rlchain.inference.policy_player import play_policies
        was_training = models.training
        try:
            play_policies(params, None, episodes, deterministic, quiet=True, models=models)
        finally:
            models.train(was_training)
        episodes_out = self.episodes(self.logs[-1])
        return {"env_runners": {**episodes_out, "num_episodes": self.logs[-1].finished},
                "episode_reward_mean": episodes_out["episode_return_mean"]}
