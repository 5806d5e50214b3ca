"""RLlib's episode results of one ``train()`` (``env_runners/episode_return_mean``, ``episode_len_mean``,
``episode_return_min`` / ``max``, ``num_episodes``): the episodes that ended during that ``train()`` only.

What RLlib 2.60 reports (read in its source, ``SingleAgentEnvRunner._log_episode_metrics`` and
``utils/metrics/stats``, and checked against every episode's return logged by a callback in real RLlib): each
env runner logs a finished episode's return into a window of ``ceil(metrics_num_episodes_for_smoothing /
num_env_runners)`` values, and that window is emptied each time the algorithm collects the runner's metrics
(once per ``train()``); the algorithm reports the mean of the runners' means (a runner that finished no episode
gives NaN and is left out; none finished at all: NaN). So it is not "the last 100 episodes": near CartPole's 450
one iteration of 4,000 env steps ends about 9 episodes, and a 100-episode mean would lag about 11 iterations
(44k env steps) behind the policy.

The face counts the same episodes: with two or more env runners it notes which runner each finished episode
belongs to (:class:`IterationEpisodes` on rlchain's per-step event), with fewer it reads the episodes that
rlchain's episode tracker finished since the last ``train()`` (no per-step work).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from rlchain.training.events import Callback

Episode = tuple[float, int]
"""One finished episode: (return, length)."""


def _mean(values: Sequence[float]) -> float:
    return sum(values) / len(values) if values else math.nan


def _nanmean(values: Sequence[float]) -> float:
    return _mean([v for v in values if not math.isnan(v)])


def episode_metrics(episodes: Sequence[tuple[float, float]]) -> dict[str, float]:
    """RLlib's episode results of one list of (return, length) episodes: means, min and max of the returns (NaN
    without an episode) and ``num_episodes`` (an evaluation's, an evaluation runner's since its last report)."""
    returns = [r for r, _ in episodes]
    return {"episode_return_mean": _mean(returns), "episode_return_min": min(returns) if returns else math.nan,
            "episode_return_max": max(returns) if returns else math.nan,
            "episode_len_mean": _mean([float(n) for _, n in episodes]), "num_episodes": len(episodes)}


def iteration_metrics(by_runner: Sequence[Sequence[Episode]], window: int) -> dict[str, float]:
    """RLlib's episode results of one iteration from the episodes each env runner finished in it (in order).

    Each runner keeps its last ``ceil(window / len(by_runner))`` episodes; the means are the mean of the runners'
    means (runners without an episode left out), min / max over the kept episodes, ``num_episodes`` all of them.
    """
    keep = max(1, math.ceil(window / max(1, len(by_runner))))
    kept = [list(episodes)[-keep:] for episodes in by_runner]
    returns = [r for episodes in kept for r, _ in episodes]
    return {"episode_return_mean": _nanmean([_mean([r for r, _ in eps]) for eps in kept]),
            "episode_len_mean": _nanmean([_mean([float(n) for _, n in eps]) for eps in kept]),
            "episode_return_min": min(returns) if returns else math.nan,
            "episode_return_max": max(returns) if returns else math.nan,
            "num_episodes": sum(len(episodes) for episodes in by_runner)}


class IterationEpisodes(Callback):
    """The episodes finished since the last :meth:`take`, by env runner; :meth:`take` gives RLlib's results.

    ``runners`` env runners of ``envs_per_runner`` envs each (rlchain's env ``i`` is runner
    ``i // envs_per_runner``). With two or more runners it is added to the run's callbacks (per-step event:
    which env each episode ended in); with one it only reads the tracker's newly finished games at :meth:`take`.
    """

    def __init__(self, runners: int, envs_per_runner: int, window: int) -> None:
        self.runners = max(1, int(runners))
        self.envs_per_runner = max(1, int(envs_per_runner))
        self.window = max(1, int(window))
        self.per_runner = self.runners > 1
        self._episodes: list[list[Episode]] = [[] for _ in range(self.runners)]
        self._seen = 0  # the tracker's games count at the last look

    def on_env_step(self, ctx: Any, result: Any, done_indices: Any, rows: slice) -> None:
        if not done_indices.numel():  # the common step: no episode ended, nothing read
            return
        tracker = ctx.episode_tracker
        new = self._new_games(tracker)
        if not new:
            return
        returns, lengths = list(tracker.finished_returns)[-new:], list(tracker.finished_lengths)[-new:]
        envs = [(rows.start or 0) + int(i) for i in done_indices.tolist()]
        if len(envs) != len(returns):  # the tracker counts whole games (Atari lives): no env per game
            envs = [envs[0]] * len(returns)
        for env, ret, length in zip(envs, returns, lengths):
            runner = min(env // self.envs_per_runner, self.runners - 1)
            self._episodes[runner].append((float(ret), int(length)))

    def _new_games(self, tracker: Any) -> int:
        games = int(tracker.games)
        new = games - self._seen
        self._seen = games
        return max(0, min(new, len(tracker.finished_returns)))

    def sync(self, tracker: Any) -> None:
        """Forget what was collected and count from the tracker's games now (the run starts, a restore)."""
        self._episodes = [[] for _ in range(self.runners)]
        self._seen = int(tracker.games)

    def take(self, tracker: Any) -> dict[str, float]:
        """RLlib's episode results of the iteration that just ended; starts the next one."""
        finished = max(0, int(tracker.games) - self._seen)
        if not self.per_runner:
            new = self._new_games(tracker)  # the tracker keeps its last games_to_track of them
            if new:
                returns, lengths = list(tracker.finished_returns)[-new:], list(tracker.finished_lengths)[-new:]
                self._episodes[0].extend((float(r), int(n)) for r, n in zip(returns, lengths))
        out = iteration_metrics(self._episodes, self.window)
        if not self.per_runner:
            out["num_episodes"] = finished
        self._episodes = [[] for _ in range(self.runners)]
        return out
