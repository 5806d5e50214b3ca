"""RLlib's ``MultiAgentEnv`` trained on rlchain's multi-policy PPO.

RLlib's multi-agent API: ``reset() -> (obs, infos)`` and ``step(action_dict) -> (obs, rewards, terminateds,
truncateds, infos)``, dicts keyed by agent id, ``"__all__"`` in ``terminateds`` / ``truncateds`` ending the
episode. An agent acts at a step when the last ``obs`` dict holds it (turn-based games send only the mover's);
it leaves when its own ``terminateds`` / ``truncateds`` entry is True, and may appear mid-episode by getting an
observation. :class:`~rlchain.envs.wrappers.multi_agent_parallel.ParallelView` shows one such env as
PettingZoo's ParallelEnv, which rlchain's PettingZoo backend steps (:mod:`rlchain.envs.backends.pettingzoo_env`):
steps where an agent is absent or waits are masked out of its policy's returns and loss
(:mod:`rlchain.algos.multi_policy.masked`), and rewards an agent gets while waiting are summed into its next step.

``.multi_agent(policies=..., policy_mapping_fn=..., policies_to_train=...)``: each policy gets its own rlchain
model and optimizer. ``policy_mapping_fn(agent_id, episode)`` is first asked for :data:`PROBES` made-up episodes:
an agent it always maps to one policy plays that policy for the run; an agent it maps to several (a random
opponent per episode) gets a slot in each of them (rlchain's ``policy_mapping`` with a list), and every env copy
asks the function again at each episode start (:class:`ParallelView`'s ``choose``), as RLlib's env runner does
when the agent appears. An answer the probes never gave is a one-line error.
"""

from __future__ import annotations

import copy
import glob
import itertools
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from rlchain import env_configurations
from rlchain.config.errors import ConfigError
from rlchain.envs.backends.pettingzoo_env import PettingZooVecEnv
from rlchain.envs.wrappers.multi_agent_parallel import ALL, EpisodeLog, ParallelView, agent_ids_of, space_of
from rlchain.inference.policy_player import play_policies
from rlchain.rllib import translate
from rlchain.rllib.core import DEFAULT_MODULE_ID
from rlchain.rllib.face_error import FaceNotOffered
from rlchain.rllib.multi_agent_window import IterationLog, multi_agent_metrics

_COUNTER = itertools.count(1)
PROBES = 64
"""Made-up episodes ``policy_mapping_fn`` is asked for up front: the policies each agent may play."""
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
        return space_of(self.observation_spaces, self.observation_space, agent_id)

    def get_action_space(self, agent_id: Any) -> gym.Space:
        return space_of(self.action_spaces, self.action_space, agent_id)

    def with_agent_groups(self, groups: dict, obs_space: Any = None, act_space: Any = None) -> Any:
        """RLlib's agent groups (several agents as one agent of Tuple spaces) are refused in one line."""
        raise FaceNotOffered("MultiAgentEnv.with_agent_groups is not offered: the face trains every agent id as an "
                             "agent of its own (a group's Tuple actions are not mapped); give the agents one policy "
                             "with policy_mapping_fn to share it")

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


def register(make: Callable[[int], Any], agent_ids: list[Any], logs: list[EpisodeLog], window: int = 100,
             runners: int = 1, envs_per_runner: int = 1,
             chooser: Callable[[int], Callable[[list[Any]], dict[Any, str]]] | None = None) -> str:
    """A fresh env name whose builder steps ``make(0..n-1)`` (each a MultiAgentEnv) with rlchain's PettingZoo
    backend; each built vector env's finished episodes go to a new :class:`IterationLog` appended to ``logs`` (the
    training env's is the first, an evaluation env's the last), noting each episode's env runner. ``chooser(i)``:
    what env copy ``i`` asks at each episode start for its agents' policies (None: a mapping for the run)."""
    name = f"rllib_multi_agent_env_{next(_COUNTER)}"

    def build(num_envs: int, seed: int | None, *, render: bool = False, **env_config: Any) -> PettingZooVecEnv:
        if env_config:
            raise ConfigError("", "params.config.env_config", "an RLlib MultiAgentEnv takes its env_config from "
                                                              "the RLlib config")
        index = itertools.count()
        log = IterationLog(window, runners, envs_per_runner)
        logs.append(log)

        def view() -> ParallelView:
            i = next(index)
            return ParallelView(make(i), agent_ids, log.for_copy(i), None if chooser is None else chooser(i))

        return PettingZooVecEnv(view, num_envs, seed)

    env_configurations.register(name, {"vecenv_creator": build})
    return name


# ----- the policies ------------------------------------------------------------------------------------------------
class _Episode:
    """What a policy_mapping_fn may read of the episode it is asked in (RLlib's MultiAgentEpisode)."""

    def __init__(self, index: int, env_id: int = 0) -> None:
        self.id_ = self.episode_id = f"episode_{index}"
        self.env_id = env_id
        self.worker_index = 0


def _ask(fn: Callable[..., Any], agent: Any, episode: _Episode) -> Any:
    try:
        return fn(agent, episode, worker=None)
    except TypeError:
        return fn(agent, episode)


def policy_names(config: Any) -> tuple[list[str], dict[str, Any]]:
    """(policy ids, policy id -> its RLlib entry) of ``.multi_agent(policies=...)``: a set / list of ids or a
    dict of id -> None / PolicySpec / (cls, obs_space, act_space, config)."""
    where = f"{type(config).__name__}.multi_agent()"
    policies = config._settings.get("policies")
    if policies is None:
        return [DEFAULT_MODULE_ID], {DEFAULT_MODULE_ID: None}
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


def agent_policies(config: Any, agent_ids: list[Any], names: list[str]) -> dict[Any, list[str]]:
    """agent id -> the policies ``policy_mapping_fn`` maps it to over :data:`PROBES` made-up episodes (one: the
    agent plays it for the run), in the order of ``names``."""
    where = f"{type(config).__name__}.multi_agent()"
    fn = config._settings.get("policy_mapping_fn")
    if fn is None:
        if len(names) == 1:
            return {agent: [names[0]] for agent in agent_ids}
        raise ConfigError(where, "policy_mapping_fn", f"required with several policies ({', '.join(names)})")
    out = {}
    episodes = [_Episode(index) for index in range(PROBES)]
    for agent in agent_ids:
        answers = set()
        for episode in episodes:
            answer = _ask(fn, agent, episode)
            if answer not in names:
                raise ConfigError(where, "policy_mapping_fn", f"maps agent {agent!r} to {answer!r}, not one of the "
                                                              f"policies ({', '.join(names)})")
            answers.add(answer)
        out[agent] = [pid for pid in names if pid in answers]
    return out


def episode_chooser(config: Any, mapping: dict[Any, list[str]]) -> Callable[[int], Callable] | None:
    """What env copy ``i`` asks at each episode start: ``policy_mapping_fn`` for every agent, with a fresh
    episode (``env_id`` the copy); None when every agent plays one policy for the run."""
    if all(len(pids) == 1 for pids in mapping.values()):
        return None
    fn = config._settings["policy_mapping_fn"]
    where = f"{type(config).__name__}.multi_agent()"
    counter = itertools.count(PROBES)

    def chooser(i: int) -> Callable[[list[Any]], dict[Any, str]]:
        def choose(agents: list[Any]) -> dict[Any, str]:
            episode = _Episode(next(counter), env_id=i)
            out = {}
            for agent in agents:
                answer = _ask(fn, agent, episode)
                if answer not in mapping[agent]:
                    raise ConfigError(where, "policy_mapping_fn", f"maps agent {agent!r} to {answer!r} in "
                                      f"{episode.id_}, which {PROBES} episodes asked up front never did (it "
                                      f"answered {', '.join(mapping[agent])}): rlchain gives each policy its "
                                      f"agent slots before training")
                out[agent] = answer
            return out
        return choose

    return chooser


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


def ppo_config(config: Any, base: dict[str, Any], view: ParallelView, mapping: dict[Any, list[str]],
               network_of: Callable[..., dict]) -> dict[str, Any]:
    """The rlchain multi-policy PPO config: ``base`` (the single-agent translation, its keys shared by every
    policy) with a ``multi_agent`` block: each policy's network (``network_of(policy, obs_space, act_space)``)
    and model for its agents' spaces, the agent -> policy mapping (``mapping``, :func:`agent_policies`: a list
    where the agent plays one of several per episode), the trained policies."""
    names, _ = policy_names(config)
    agents = [view._ids[a] for a in view.possible_agents]
    params = base["params"]
    policies: dict[str, Any] = {}
    for pid in names:
        mine = [str(a) for a in agents if pid in mapping[a]]
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
             "policy_mapping": {glob.escape(str(a)): pids[0] if len(pids) == 1 else pids
                                for a, pids in mapping.items()},
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
        self.mapping = agent_policies(config, self.agent_ids, self.names)  # agent -> the policies it may play
        self.chooser = episode_chooser(config, self.mapping)  # None: one policy per agent for the run
        self.spaces = {}  # policy id -> (observation space, action space) of its agents
        for agent, pids in self.mapping.items():
            for pid in pids:
                self.spaces.setdefault(pid, (self.view.observation_space(str(agent)),
                                             self.view.action_space(str(agent))))
        self.trained = trained_policies(config, self.names)  # None: every policy
        self.logs: list[EpisodeLog] = []

    def rlchain_config(self, config: Any, make: Callable[[int], Any], run: dict[str, Any],
                       network_of: Callable[..., dict]) -> tuple[str, dict[str, Any]]:
        """(the registered env name, the rlchain multi-policy PPO config)."""
        settings = config._settings
        window = int(settings.get("metrics_num_episodes_for_smoothing") or 100)
        env_name = register(make, self.agent_ids, self.logs, window, max(1, int(settings.get("num_env_runners") or 0)),
                            max(1, int(settings.get("num_envs_per_env_runner") or 1)), self.chooser)
        base = translate.ppo_config(config, env_name, False, run, rllib_batch=False)
        return env_name, ppo_config(config, base, self.view, self.mapping, network_of)

    def episodes(self, log: EpisodeLog | None = None) -> dict[str, Any]:
        """RLlib's env-runner episode metrics of the episodes ``log`` (default: the training env's) finished since
        the last call (:mod:`rlchain.rllib.multi_agent_window`: per iteration, as RLlib reports them)."""
        log = log or (self.logs[0] if self.logs else IterationLog())
        module_of = {str(agent): pids[0] for agent, pids in self.mapping.items()}  # else each episode's own
        out = log.take(module_of) if isinstance(log, IterationLog) else multi_agent_metrics([], log.window, module_of)
        out["num_episodes_lifetime"] = log.finished
        out["agent_episode_returns_mean"] = {self._id(a): v for a, v in out["agent_episode_returns_mean"].items()}
        return out

    def _id(self, agent: str) -> Any:
        return self.view._ids.get(agent, agent)

    def learners(self, stats: dict[str, float], lr: float, last: dict[str, dict[str, float]] | None = None
                 ) -> dict[str, dict[str, float]]:
        """RLlib's ``learners/<policy>`` results (trained policies only) from rlchain's per-policy tags; the losses
        and KL of each policy's last minibatch where ``last`` (policy -> its agent's last minibatch's statistics)
        has them, as RLlib logs them (``window=1``), else the update's means."""
        nan = float("nan")
        out = {}
        for pid in self.names:
            if pid not in self.spaces or (self.trained is not None and pid not in self.trained):
                continue
            own = (last or {}).get(pid) or {}
            tag = (lambda kind, key, pid=pid, own=own: own.get(key, stats.get(f"{kind}/{pid}/{key}", nan)))
            out[pid] = {"policy_loss": tag("losses", "a_loss"), "vf_loss": tag("losses", "c_loss"),
                        "entropy": tag("losses", "entropy"), "mean_kl_loss": tag("info", "kl"),
                        "total_loss": own.get("loss", nan),
                        "curr_lr": stats.get(f"info/{pid}/last_lr", lr),
                        "curr_entropy_coeff": stats.get(f"info/{pid}/entropy_coef", 0.0)}
        return out

    def evaluate(self, params: Any, models: Any, episodes: int, deterministic: bool) -> dict[str, Any]:
        """``episodes`` episodes of every policy on a fresh env (rlchain's multi-policy play loop); RLlib's
        evaluation results."""
        was_training = models.training
        try:
            play_policies(params, None, episodes, deterministic, quiet=True, models=models)
        finally:
            models.train(was_training)
        episodes_out = self.episodes(self.logs[-1])
        return {"env_runners": episodes_out,
                "episode_reward_mean": episodes_out["episode_return_mean"]}
