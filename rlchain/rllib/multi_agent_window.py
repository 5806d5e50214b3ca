"""RLlib's episode results of one ``train()`` for a MultiAgentEnv (``MultiAgentEnvRunner._log_episode_metrics``):
the episodes that ended during that ``train()`` only, as for one agent (:mod:`rlchain.rllib.episode_window`).

An episode's return is the sum over its agents, its length the env steps; ``agent_episode_returns_mean`` maps
each agent id to the mean of its own return over the episodes it was in, ``module_episode_returns_mean`` each
policy to the mean, over the episodes its agents were in, of their returns summed in that episode. Each env
runner keeps its last ``ceil(metrics_num_episodes_for_smoothing / num_env_runners)`` episodes of the iteration;
every mean is the mean of the runners' means (a runner without the key left out).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from rlchain.envs.wrappers.multi_agent_parallel import EpisodeLog
from rlchain.rllib.episode_window import iteration_metrics

AgentEpisode = tuple[float, int, dict[str, float], dict[str, str]]
"""One finished multi-agent episode: (return summed over agents, length in env steps, {agent: its return}, {agent:
the policy it played in this episode, where one was chosen for it}); the last item may be left out."""


def _mean_of_means(per_runner: Sequence[Mapping[Any, list[float]]]) -> dict[Any, float]:
    """{key: mean over runners of the runner's mean} for every key a runner logged."""
    keys = dict.fromkeys(k for runner in per_runner for k in runner)
    out = {}
    for key in keys:
        means = [sum(r[key]) / len(r[key]) for r in per_runner if r.get(key)]
        out[key] = sum(means) / len(means)
    return out


def multi_agent_metrics(by_runner: Sequence[Sequence[AgentEpisode]], window: int,
                        module_of: Mapping[str, str]) -> dict[str, Any]:
    """RLlib's multi-agent episode results of one iteration from each env runner's finished episodes (in order);
    ``module_of`` maps an agent id (as a string) to its policy id, unless the episode names the agent's policy."""
    keep = max(1, math.ceil(window / max(1, len(by_runner))))
    kept = [list(episodes)[-keep:] for episodes in by_runner]
    out: dict[str, Any] = iteration_metrics([[(e[0], e[1]) for e in eps] for eps in by_runner], window)
    agents, modules = [], []
    for episodes in kept:
        per_agent: dict[str, list[float]] = {}
        per_module: dict[str, list[float]] = {}
        for episode in episodes:
            returns, chosen = episode[2], (episode[3] if len(episode) > 3 else None) or {}
            summed: dict[str, float] = {}
            for agent, value in returns.items():
                per_agent.setdefault(agent, []).append(float(value))
                pid = chosen.get(agent) or module_of.get(agent, agent)
                summed[pid] = summed.get(pid, 0.0) + float(value)
            for pid, value in summed.items():
                per_module.setdefault(pid, []).append(value)
        agents.append(per_agent)
        modules.append(per_module)
    out["agent_episode_returns_mean"] = _mean_of_means(agents)
    out["module_episode_returns_mean"] = _mean_of_means(modules)
    return out


class IterationLog(EpisodeLog):
    """rlchain's multi-agent EpisodeLog (the last ``window`` episodes, the lifetime count) that also keeps, by env
    runner, the episodes finished since the last :meth:`take`. Each env copy writes through :meth:`for_copy`
    (copy ``i`` belongs to runner ``i // envs_per_runner``)."""

    def __init__(self, window: int = 100, runners: int = 1, envs_per_runner: int = 1) -> None:
        super().__init__(window)
        self.runners = max(1, int(runners))
        self.envs_per_runner = max(1, int(envs_per_runner))
        self._new: list[list[AgentEpisode]] = [[] for _ in range(self.runners)]

    def for_copy(self, index: int) -> _CopyLog:
        """What env copy ``index`` writes its finished episodes to."""
        return _CopyLog(self, min(index // self.envs_per_runner, self.runners - 1))

    def add(self, total: float, length: int, per_agent: dict[str, float], modules: dict[str, str] | None = None,
            runner: int = 0) -> None:
        super().add(total, length, per_agent, modules)
        self._new[runner].append((float(total), int(length), dict(per_agent), dict(modules or {})))

    def take(self, module_of: Mapping[str, str]) -> dict[str, Any]:
        """RLlib's episode results of the episodes finished since the last call; starts the next iteration."""
        out = multi_agent_metrics(self._new, self.window, module_of)
        self._new = [[] for _ in range(self.runners)]
        return out


class _CopyLog:
    """One env copy's handle on an :class:`IterationLog` (what ParallelView calls ``add`` on)."""

    def __init__(self, log: IterationLog, runner: int) -> None:
        self.log, self.runner = log, runner

    def add(self, total: float, length: int, per_agent: dict[str, float],
            modules: dict[str, str] | None = None) -> None:
        self.log.add(total, length, per_agent, modules, runner=self.runner)
