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

import contextlib
import math
import time
from collections.abc import Iterator
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
    """RLlib 2.60's ``MetricsLogger``: values by key (a string or a tuple of nested keys), reduced into each result
    dict. A key's settings are those of its first ``log_value``; later calls add values only. The reduce kinds:

    - ``reduce=None`` without ``window`` (the default): ``"ema"``, an exponential moving average (``ema_coeff``,
      default 0.01) that carries over from one result to the next;
    - ``"mean"`` / ``"min"`` / ``"max"`` / ``"sum"``: over the last ``window`` values (kept across results), or
      without a window over the values since the last result (``reduce=None`` with a window is ``"mean"``);
    - ``"lifetime_sum"`` (or ``"sum"`` with ``clear_on_reduce=False``): the running total;
    - ``"item"``: the last value logged; ``"item_series"``: the values logged (the last ``window``), any type.
    """

    KINDS = ("ema", "mean", "min", "max", "sum", "lifetime_sum", "item", "item_series")

    def __init__(self) -> None:
        self._values: dict[str, list[Any]] = {}
        self._reduce: dict[str, tuple[str, int | None, float]] = {}
        self._running: dict[str, float] = {}  # an EMA's value or a lifetime sum's total
        self._last: dict[str, Any] = {}
        self._fresh: set[str] = set()  # keys logged since the last result

    @staticmethod
    def _name(key: Any) -> str:
        return "/".join(key) if isinstance(key, (tuple, list)) else str(key)

    def log_value(self, key: Any, value: Any, reduce: str | None = None, window: int | None = None,
                  ema_coeff: float | None = None, clear_on_reduce: Any = None, **kwargs: Any) -> None:
        name = self._name(key)
        if name not in self._reduce:
            kind = reduce or ("mean" if window is not None else "ema")
            if kind == "mean" and ema_coeff is not None and window is None:
                kind = "ema"  # RLlib's older spelling: reduce="mean" with an ema_coeff
            if kind == "sum" and clear_on_reduce is False:
                kind = "lifetime_sum"
            if kind not in self.KINDS:
                raise ValueError(f"metrics_logger.log_value('{name}'): reduce '{kind}' is not one of "
                                 f"{', '.join(self.KINDS)}")
            self._reduce[name] = (kind, int(window) if window else None, 0.01 if ema_coeff is None else ema_coeff)
        kind, _, coeff = self._reduce[name]
        if isinstance(value, torch.Tensor) and value.numel() == 1:
            value = value.item()
        self._fresh.add(name)
        if kind == "ema":
            value = float(value)
            old = self._running.get(name)
            self._running[name] = value if old is None else (1.0 - coeff) * old + coeff * value
        elif kind == "lifetime_sum":
            self._running[name] = self._running.get(name, 0.0) + float(value)
        else:
            self._values.setdefault(name, []).append(value if kind.startswith("item") else float(value))

    def log_dict(self, stats: dict[str, Any], *, key: Any = None, reduce: str | None = None,
                 window: int | None = None, **kwargs: Any) -> None:
        prefix = "" if key is None else self._name(key) + "/"
        for name, value in stats.items():
            if isinstance(value, dict):
                self.log_dict(value, key=prefix + name, reduce=reduce, window=window, **kwargs)
            else:
                self.log_value(prefix + name, value, reduce=reduce, window=window, **kwargs)

    @contextlib.contextmanager
    def log_time(self, key: Any, reduce: str | None = None, window: int | None = None,
                 ema_coeff: float | None = None, **kwargs: Any) -> Iterator[None]:
        """``with metrics_logger.log_time(key):`` logs the block's seconds under ``key``."""
        start = time.perf_counter()
        try:
            yield
        finally:
            self.log_value(key, time.perf_counter() - start, reduce=reduce, window=window, ema_coeff=ema_coeff)

    def peek(self, key: Any, default: Any = None, **kwargs: Any) -> Any:
        """A key's current value; a key above others (``"evaluation"``) gives their values as a nested dict."""
        name = self._name(key)
        if name in self._running:
            return self._running[name]
        if self._values.get(name):
            return self._reduce_one(name)
        if name in self._last:
            return self._last[name]
        below = {n[len(name) + 1:]: self.peek(n) for n in {*self._last, *self._running, *self._values}
                 if n.startswith(name + "/")}
        return nested(below) if below else default

    def aggregate(self, stats_dicts: list[dict[str, Any]], *, key: Any = None) -> None:
        """Merge env runners' metric dicts (``get_metrics()``) under ``key`` (``peek(key)`` reads them back, the
        next result does not), as RLlib's ``aggregate``: a ``*_mean`` weighted by its dict's ``num_episodes``, a
        ``*_min`` / ``*_max`` the extreme, a ``num_*`` count summed, any other number averaged."""
        prefix = "" if key is None else self._name(key) + "/"
        rows = [_flat(d) for d in stats_dicts]
        for name in dict.fromkeys(n for row in rows for n in row):
            leaf = name.rsplit("/", 1)[-1]
            count = name[:len(name) - len(leaf)] + "num_episodes"
            pairs = [(row[name], row.get(count, 1) if leaf.endswith("_mean") else 1) for row in rows
                     if isinstance(row.get(name), (int, float)) and not math.isnan(row[name])]
            if not pairs:
                self._last[prefix + name] = math.nan
            elif leaf.startswith("num_"):
                self._last[prefix + name] = sum(v for v, _ in pairs)
            elif leaf.endswith(("_min", "_max")):
                self._last[prefix + name] = (min if leaf.endswith("_min") else max)(v for v, _ in pairs)
            else:
                weight = sum(w for _, w in pairs)
                self._last[prefix + name] = sum(v * w for v, w in pairs) / weight if weight else math.nan

    merge_and_log_n_dicts = aggregate  # RLlib's older name

    def remember(self, result: dict[str, Any], prefix: str = "") -> None:
        """Keep a result's values for :meth:`peek` (RLlib's ``algo.metrics.peek(("env_runners",
        "num_env_steps_sampled_lifetime"))``), below anything logged under the same key."""
        for key, value in result.items():
            if isinstance(value, dict):
                self.remember(value, f"{prefix}{key}/")
            elif f"{prefix}{key}" not in self._reduce:
                self._last[f"{prefix}{key}"] = value

    def _reduce_one(self, name: str) -> Any:
        kind, window, _ = self._reduce[name]
        if kind in ("ema", "lifetime_sum"):
            return self._running[name]
        values = self._values[name][-window:] if window else self._values[name]
        if kind == "item":
            return values[-1]
        if kind == "item_series":
            return list(values)
        if not values:
            return math.nan
        return float({"sum": sum, "min": min, "max": max}.get(kind, lambda v: sum(v) / len(v))(values))

    def reduce(self) -> dict[str, Any]:
        """Every key's reduced value for a result: running averages and totals, the last item and windowed values
        carry over to the next result; values without a window (and series) only when logged since the last."""
        out = {}
        for name, (kind, window, _) in self._reduce.items():
            carried = kind in ("ema", "lifetime_sum", "item") or (window and kind != "item_series")
            if name in self._fresh or (carried and (name in self._running or self._values.get(name))):
                out[name] = self._last[name] = self._reduce_one(name)
            if name in self._values and kind != "item":
                self._values[name] = self._values[name][-window:] if window and kind != "item_series" else []
        self._fresh.clear()
        return out


def _flat(values: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in values.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}/"))
        else:
            out[f"{prefix}{key}"] = value
    return out


class Episode:
    """What an episode callback gets of one training episode (RLlib's ``SingleAgentEpisode`` reads)."""

    def __init__(self, env_index: int) -> None:
        self.env_index = env_index
        self.custom_data: dict[str, Any] = {}
        self.is_done = False
        self.id_ = f"episode_{env_index}"
        self.rewards: list[float] = []  # the return and the length read it
        self.last_obs: Any = None  # kept only where a callback overrides on_episode_step
        self.last_info: dict[str, Any] = {}
        self._temporary: dict[str, list[Any]] = {}

    def get_return(self) -> float:
        return float(sum(self.rewards))

    def get_length(self) -> int:
        return len(self.rewards)

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
        return len(self.rewards)


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

    def __init__(self, callbacks: list[RLlibCallback], logger: MetricsLogger, env_runner: Any = None) -> None:
        self.callbacks = callbacks
        self.logger = logger
        self.env_runner = env_runner  # RLlib's env_runner argument (rlchain.rllib.env_runner_group.EnvRunner)
        self.episodes: dict[int, Episode] = {}
        self.steppers = [cb for cb in callbacks if steps_episodes(cb)]
        self.vector_env: Any = None

    def _episode(self, index: int) -> Episode:
        episode = self.episodes.get(index)
        if episode is None:
            episode = self.episodes[index] = Episode(index)
            for cb in self.callbacks:
                cb.on_episode_start(episode=episode, metrics_logger=self.logger, env_index=index, **self._where())
        return episode

    def drop_running(self) -> None:
        """Forget the episodes in progress (the envs were rebuilt, ``EnvRunner.make_env``): as RLlib's runner, no
        ``on_episode_end`` for them, and each env's next step starts a fresh episode (``on_episode_start``)."""
        self.episodes.clear()

    def _where(self) -> dict[str, Any]:
        """RLlib's other episode-callback arguments: ``env_runner``, ``env`` (the vector env), ``rl_module``."""
        runner = self.env_runner
        return {"env_runner": runner, "env": self.vector_env, "rl_module": runner.module if runner else None}

    def on_env_step(self, ctx: Any, result: Any, done_indices: Any, rows: slice) -> None:
        if self.vector_env is None:
            self.vector_env = gymnasium_vector_env(ctx.training_env)
        rewards = torch.as_tensor(result.reward).reshape(-1).tolist()
        start = rows.start or 0
        for i, reward in enumerate(rewards):
            self._episode(start + i).rewards.append(float(reward))
        if self.steppers:
            self._step_events(ctx, result, set(done_indices.tolist()), start, len(rewards))
        for row in done_indices.tolist():
            episode = self.episodes.pop(start + int(row))
            episode.is_done = True
            for cb in self.callbacks:
                cb.on_episode_end(episode=episode, metrics_logger=self.logger, env_index=episode.env_index,
                                  **self._where())

    def _step_events(self, ctx: Any, result: Any, done: set[int], start: int, count: int) -> None:
        """``on_episode_step`` for each row: the episode's last observation and info. At an episode's last step
        (``episode.is_done``) the vector env has already reset that row (same-step auto-reset): the final
        observation is the episode's, not the env's."""
        final = result.final_obs
        for i in range(count):
            episode = self.episodes[start + i]
            source = final if i in done and final is not None else result.obs
            episode.last_obs = row_of(source, i)
            episode.last_info = info_row(result.infos, i)
            episode.is_done = i in done
            for cb in self.steppers:
                cb.on_episode_step(episode=episode, metrics_logger=self.logger, env_index=episode.env_index,
                                   **self._where())


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
