"""RLlib's ``RLlibCallback`` and ``MetricsLogger`` over rlchain's events.

The face calls ``on_algorithm_init`` when the algorithm is built, ``on_train_result`` after each ``train()``
(the result dict may be changed in place), ``on_episode_start`` / ``on_episode_step`` / ``on_episode_end`` when a
training episode starts / steps / ends (an :class:`Episode` with ``get_return()``, ``get_length()``,
``custom_data``, ``add_temporary_timestep_data``; ``env`` is the gymnasium vector env stepping it where the envs
step in this process), and ``on_evaluate_start`` / ``on_evaluate_end`` around ``evaluate()``. Values logged with
``metrics_logger.log_value(key, value)`` appear in the next result dict (episode callbacks' under
``env_runners``) and go to rlchain's log writers (TensorBoard, wandb, ...) under ``custom/<key>``.
Other events RLlib has (``on_sample_end``, ``on_environment_created``...) are accepted and not called.
"""

from __future__ import annotations

import math
from typing import Any

import torch

from rlchain.training.events import Callback


class RLlibCallback:
    """Override the events you need (RLlib's names and keyword arguments); each is a no-op by default."""

    def on_algorithm_init(self, *, algorithm: Any, metrics_logger: Any = None, **kwargs: Any) -> None:
        pass

    def on_train_result(self, *, algorithm: Any, metrics_logger: Any = None, result: dict, **kwargs: Any) -> None:
        pass

    def on_episode_start(self, *, episode: Any, env_runner: Any = None, metrics_logger: Any = None,
                         env: Any = None, env_index: int = 0, rl_module: Any = None, **kwargs: Any) -> None:
        pass

    def on_episode_step(self, *, episode: Any, env_runner: Any = None, metrics_logger: Any = None,
                        env: Any = None, env_index: int = 0, rl_module: Any = None, **kwargs: Any) -> None:
        pass

    def on_episode_end(self, *, episode: Any, env_runner: Any = None, metrics_logger: Any = None,
                       env: Any = None, env_index: int = 0, rl_module: Any = None, **kwargs: Any) -> None:
        pass

    def on_evaluate_start(self, *, algorithm: Any, metrics_logger: Any = None, **kwargs: Any) -> None:
        pass

    def on_evaluate_end(self, *, algorithm: Any, metrics_logger: Any = None, evaluation_metrics: dict,
                        **kwargs: Any) -> None:
        pass

    def on_checkpoint_loaded(self, *, algorithm: Any, **kwargs: Any) -> None:
        pass

    def on_sample_end(self, **kwargs: Any) -> None:
        pass

    def on_environment_created(self, **kwargs: Any) -> None:
        pass


DefaultCallbacks = RLlibCallback  # RLlib's older name


class MetricsLogger:
    """RLlib's ``MetricsLogger``: values by key, reduced when the result dict is made (mean over the last
    ``window`` values, or sum / min / max over all since the last result)."""

    def __init__(self) -> None:
        self._values: dict[str, list[float]] = {}
        self._reduce: dict[str, tuple[str, int | None]] = {}
        self._last: dict[str, float] = {}

    def log_value(self, key: Any, value: Any, reduce: str = "mean", window: int | None = None,
                  ema_coeff: float | None = None, clear_on_reduce: bool = False, **kwargs: Any) -> None:
        name = "/".join(key) if isinstance(key, (tuple, list)) else str(key)
        self._values.setdefault(name, []).append(float(value.item() if isinstance(value, torch.Tensor) else value))
        self._reduce[name] = (reduce or "mean", window)

    def log_dict(self, stats: dict[str, Any], *, key: Any = None, reduce: str = "mean", window: int | None = None,
                 **kwargs: Any) -> None:
        prefix = "" if key is None else ("/".join(key) if isinstance(key, (tuple, list)) else str(key)) + "/"
        for name, value in stats.items():
            if isinstance(value, dict):
                self.log_dict(value, key=prefix + name, reduce=reduce, window=window)
            else:
                self.log_value(prefix + name, value, reduce=reduce, window=window)

    def peek(self, key: Any, default: Any = None) -> Any:
        name = "/".join(key) if isinstance(key, (tuple, list)) else str(key)
        if name in self._values and self._values[name]:
            return self._reduce_one(name)
        return self._last.get(name, default)

    def _reduce_one(self, name: str) -> float:
        values = self._values[name]
        how, window = self._reduce[name]
        if how == "sum":
            return float(sum(values))
        if how == "min":
            return float(min(values))
        if how == "max":
            return float(max(values))
        recent = values[-window:] if window else values
        return float(sum(recent) / len(recent)) if recent else math.nan

    def reduce(self) -> dict[str, float]:
        """The reduced values since the last call (nested by '/'); mean-reduced values keep their window."""
        out = {}
        for name in list(self._values):
            if not self._values[name]:
                continue
            out[name] = self._last[name] = self._reduce_one(name)
            how, window = self._reduce[name]
            self._values[name] = self._values[name][-window:] if how == "mean" and window else []
        return out


class Episode:
    """What an episode callback gets of one training episode (RLlib's ``SingleAgentEpisode`` reads)."""

    def __init__(self, env_index: int) -> None:
        self.env_index = env_index
        self.reward_sum = 0.0
        self.length = 0
        self.custom_data: dict[str, Any] = {}
        self.is_done = False
        self.id_ = f"episode_{env_index}"
        self.rewards: list[float] = []
        self.last_obs: Any = None  # kept only where a callback overrides on_episode_step
        self.last_info: dict[str, Any] = {}
        self._temporary: dict[str, list[Any]] = {}

    def get_return(self) -> float:
        return self.reward_sum

    def get_length(self) -> int:
        return self.length

    def add_temporary_timestep_data(self, key: str, data: Any) -> None:
        """Keep ``data`` for this step under ``key`` until the episode ends (RLlib's per-episode scratch space)."""
        self._temporary.setdefault(key, []).append(data)

    def get_temporary_timestep_data(self, key: str) -> list[Any]:
        """Everything :meth:`add_temporary_timestep_data` kept under ``key``, in step order."""
        if key not in self._temporary:
            raise KeyError(f"episode has no temporary timestep data '{key}' ({', '.join(self._temporary) or 'none'})")
        return self._temporary[key]

    def get_rewards(self, indices: Any = None) -> Any:
        """The rewards of the steps so far (``indices``: one step or a slice, as a list index)."""
        return list(self.rewards) if indices is None else self.rewards[indices]

    def get_observations(self, indices: Any = -1) -> Any:
        return self._last("observation", self.last_obs, indices)

    def get_infos(self, indices: Any = -1) -> Any:
        return self._last("info", self.last_info, indices)

    @staticmethod
    def _last(what: str, value: Any, indices: Any) -> Any:
        if indices != -1:
            raise IndexError(f"the face's episode keeps its last {what} only: get_{what}s(-1) (got {indices!r})")
        return value

    def __len__(self) -> int:
        return self.length


def nested(flat: dict[str, float]) -> dict[str, Any]:
    """{'a/b': 1} -> {'a': {'b': 1}}."""
    out: dict[str, Any] = {}
    for name, value in flat.items():
        node = out
        *path, last = name.split("/")
        for part in path:
            node = node.setdefault(part, {})
        node[last] = value
    return out


def steps_episodes(callback: Any) -> bool:
    """Whether ``callback`` handles ``on_episode_step`` (a subclass's override or ``callbacks(on_episode_step=fn)``)."""
    return "on_episode_step" in vars(callback) or type(callback).on_episode_step is not RLlibCallback.on_episode_step


class EpisodeEvents(Callback):
    """rlchain's per-step event -> RLlib's episode callbacks (only built when one overrides them)."""

    def __init__(self, callbacks: list[RLlibCallback], logger: MetricsLogger) -> None:
        self.callbacks = callbacks
        self.logger = logger
        self.episodes: dict[int, Episode] = {}
        self.steppers = [cb for cb in callbacks if steps_episodes(cb)]
        self.vector_env: Any = None

    def _episode(self, index: int) -> Episode:
        episode = self.episodes.get(index)
        if episode is None:
            episode = self.episodes[index] = Episode(index)
            for cb in self.callbacks:
                cb.on_episode_start(episode=episode, metrics_logger=self.logger, env_index=index)
        return episode

    def on_env_step(self, ctx: Any, result: Any, done_indices: Any, rows: slice) -> None:
        rewards = torch.as_tensor(result.reward).reshape(-1).tolist()
        start = rows.start or 0
        for i, reward in enumerate(rewards):
            episode = self._episode(start + i)
            episode.reward_sum += float(reward)
            episode.length += 1
            episode.rewards.append(float(reward))
        if self.steppers:
            self._step_events(ctx, result, set(done_indices.tolist()), start, len(rewards))
        for row in done_indices.tolist():
            episode = self.episodes.pop(start + int(row))
            episode.is_done = True
            for cb in self.callbacks:
                cb.on_episode_end(episode=episode, metrics_logger=self.logger, env_index=episode.env_index)

    def _step_events(self, ctx: Any, result: Any, done: set[int], start: int, count: int) -> None:
        """``on_episode_step`` for each row: the episode's last observation and info. At an episode's last step
        (``episode.is_done``) the vector env has already reset that row (same-step auto-reset): the final
        observation is the episode's, not the env's."""
        if self.vector_env is None:
            self.vector_env = gymnasium_vector_env(ctx.training_env)
        final = result.final_obs
        for i in range(count):
            episode = self.episodes[start + i]
            source = final if i in done and final is not None else result.obs
            episode.last_obs = row_of(source, i)
            episode.last_info = info_row(result.infos, i)
            episode.is_done = i in done
            for cb in self.steppers:
                cb.on_episode_step(episode=episode, env=self.vector_env, metrics_logger=self.logger,
                                   env_index=episode.env_index)


def row_of(batch: Any, i: int) -> Any:
    """Row ``i`` of a batched observation (a dict of batches per key) as numpy."""
    if isinstance(batch, dict):
        return {k: row_of(v, i) for k, v in batch.items()}
    row = batch[i]
    return row.detach().cpu().numpy() if isinstance(row, torch.Tensor) else row


def info_row(infos: Any, i: int) -> dict[str, Any]:
    """Env ``i``'s info from gymnasium's vector info dict (keys with a ``_key`` mask only where it is set)."""
    if not isinstance(infos, dict):
        return {}
    out = {}
    for key, value in infos.items():
        if key.startswith("_"):
            continue
        mask = infos.get(f"_{key}")
        if mask is not None and not bool(mask[i]):
            continue
        try:
            out[key] = value[i]
        except (TypeError, IndexError, KeyError):
            continue
    return out


def gymnasium_vector_env(env: Any) -> Any:
    """The gymnasium vector env inside rlchain's env wrappers (None where the envs step elsewhere, e.g. on Ray)."""
    for _ in range(8):
        if env is None or hasattr(env, "envs"):
            return env
        env = getattr(env, "env", None) or getattr(env, "venv", None)
    return None
