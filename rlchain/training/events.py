"""Training events: callbacks a user registers from Python or names in the config.

    class MyCallback(rlchain.training.events.Callback):
        def on_epoch_end(self, ctx, stats, episodes):
            if ctx.state.epoch % 10 == 0: ctx.save(f"ep_{ctx.state.epoch}")

    Runner().load(cfg).train(callbacks=[MyCallback()])       # or in YAML:
    config: {callbacks: ["mypkg.callbacks:MyCallback"]}

Every method gets the run's :class:`~rlchain.training.callback_context.CallbackContext` first: a typed
:class:`~rlchain.training.callback_context.TrainingState` (``ctx.state``), ``request_stop``, ``save``,
``get_params`` / ``set_params`` and the run's parts (model, writer, params, env_spec, the algorithm),
read directly. A plain function ``fn(ctx, stats, episodes)`` is an ``on_epoch_end`` callback.
An rl_games ``AlgoObserver`` (before_init / after_init / process_infos / after_steps /
after_print_stats / after_clear_stats) is adapted: :class:`AlgoObserverCallback`. Built-in
in-training evaluation is one of these callbacks.

``on_env_step`` runs after every env step, so only the callbacks that override it get it: a run
without one pays nothing per step. ``close`` runs once when the run ends, however it ends.
"""

from __future__ import annotations

import time
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.errors import CallbackError
from rlchain.log import get_logger
from rlchain.registry import import_object
from rlchain.training.callback_context import CallbackContext, ObserverAlgo

log = get_logger(__name__)

EVENTS = ("on_train_start", "on_env_step", "on_rollout_end", "on_epoch_end", "on_stats_cleared", "on_evaluation",
          "on_checkpoint", "on_train_end")


class Callback:
    """Override the events you need; every method is a no-op by default. ``ctx`` is the run's
    :class:`~rlchain.training.callback_context.CallbackContext`."""

    def on_train_start(self, ctx: CallbackContext) -> None:
        """Before the first rollout (after a resume restored its state)."""

    def on_env_step(self, ctx: CallbackContext, result: Any, done_indices: Any, rows: slice) -> None:
        """After each training env step, once the episode statistics counted it.

        ``result`` is the StepResult of the envs ``rows`` (all of them, or one env group of a
        pipelined rollout; ``result.infos`` is the backend's info dict). ``done_indices``: (k,) long
        tensor on the trainer's device, the rows of ``result`` whose episode ended at this step
        (add ``rows.start`` for the env index); for multi-agent envs one row per finished env, its
        first agent's. Rows a dead Ray worker cut are not episode ends. Only callbacks that
        override this method are called.
        """

    def on_rollout_end(self, ctx: CallbackContext) -> None:
        """After an epoch's env steps (the PPO rollout, an off-policy epoch's steps), before logging."""

    def on_stats_cleared(self, ctx: CallbackContext) -> None:
        """Statistics gathered so far are stale: self-play replaced the opponent and restarted its count."""

    def on_epoch_end(self, ctx: CallbackContext, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        """After an epoch's update and logging: ``stats`` are losses/kl/lr, ``episodes`` mean reward/length."""

    def on_evaluation(self, ctx: CallbackContext, result: Any) -> None:
        """After an in-training evaluation; ``result`` is a PlayResult."""

    def on_checkpoint(self, ctx: CallbackContext, path: str, kind: str) -> None:
        """After a checkpoint was written (``kind``: best, last, ep_N)."""

    def on_train_end(self, ctx: CallbackContext, result: Any) -> None:
        """After training stopped; ``result`` is the TrainResult."""

    def close(self) -> None:
        """Release what the callback holds (envs, files). Called once when the run ends on any path
        (finished, interrupted, an env error, a divergence, a failed start), after ``on_train_end``
        when there was one."""


class FunctionCallback(Callback):
    """A plain function used as ``on_epoch_end``."""

    def __init__(self, fn: Any) -> None:
        self.fn = fn

    def on_epoch_end(self, ctx: CallbackContext, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        self.fn(ctx, stats, episodes)


class AlgoObserverCallback(Callback):
    """Drives an rl_games AlgoObserver from rlchain's events, when rl_games calls them:

    - ``before_init(name, config, experiment dir)`` and ``after_init(algo)`` at the start, where
      ``algo`` (:class:`~rlchain.training.callback_context.ObserverAlgo`) offers what observers read
      of rl_games' algo: ``writer``, ``device`` / ``ppo_device``, ``games_to_track``, ``epoch_num`` (during an
      epoch's steps the epoch running, as rl_games counts it; in after_print_stats the epochs completed),
      ``frame``, ``num_actors``, ``num_agents``, ``config``, ``experiment_dir``;
    - ``process_infos(infos, done_indices)`` after every env step: the step's infos and a (k, 1)
      long tensor of the rows whose episode ended (``nonzero()`` of the dones, one row per finished
      env for multi-agent envs), on the training device; multi-agent envs' ``{'env_infos': [...]}``
      comes as the list of per-env info dicts an rl_games vec env returns. A pipelined rollout
      (``env_groups``) calls it per env group, with that group's infos and rows;
    - ``after_steps()`` after each rollout (an off-policy epoch's env steps), before the update;
    - ``after_print_stats(frames, epoch, seconds)`` after each epoch's logging (in a run through rl_games'
      API, as rl_games: the frames counted before that epoch);
    - ``after_clear_stats()`` where rl_games clears its game statistics: when self-play replaces
      the opponent, after that epoch's ``after_print_stats`` (rlchain's own episode statistics
      are never cleared; without self-play it is not called, as in rl_games).

    Methods the observer lacks are skipped; without ``process_infos`` the env loop is not touched.
    """

    def __init__(self, observer: Any) -> None:
        self.observer = observer
        self.start = time.time()
        self._printed_epoch: int | None = None
        self._clear_pending = False
        if callable(getattr(observer, "process_infos", None)):
            self.on_env_step = self._process_infos  # type: ignore[method-assign]

    def _call(self, name: str, *args: Any) -> None:
        method = getattr(self.observer, name, None)
        if method is not None:
            method(*args)

    def on_train_start(self, ctx: CallbackContext) -> None:
        self.start = time.time()
        algo = self.algo = ObserverAlgo(ctx)
        # as before the context: the whole config as loaded, and the run folder
        self._call("before_init", ctx.params.config.name, ctx.raw_config, algo.experiment_dir)
        self._call("after_init", algo)
        algo.in_epoch = True  # the first epoch's rollout: rl_games' epoch_num is 1 by then

    def _process_infos(self, ctx: CallbackContext, result: Any, done_indices: Any, rows: slice) -> None:
        infos = result.infos
        if isinstance(infos, dict) and len(infos) == 1 and isinstance(infos.get("env_infos"), list):
            infos = infos["env_infos"]  # multi_agent.py's per-env info dicts
        self.observer.process_infos(infos, done_indices.unsqueeze(-1))

    def on_rollout_end(self, ctx: CallbackContext) -> None:
        self._call("after_steps")

    def on_epoch_end(self, ctx: CallbackContext, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        state = ctx.state
        algo = getattr(self, "algo", None)
        if algo is not None:
            algo.in_epoch = False  # epoch_num: the epochs completed, as rl_games prints them
        frames = state.frames
        if getattr(ctx.run_dir, "layout", None) == "rl_games":  # rl_games passes the frames counted before the epoch
            frames = max(0, frames - ctx.frames_per_epoch())
        self._call("after_print_stats", frames, state.epoch, time.time() - self.start)
        self._printed_epoch = state.epoch
        if self._clear_pending:
            self._clear_pending = False
            self._call("after_clear_stats")
        if algo is not None:
            algo.in_epoch = True  # the next epoch's rollout

    def on_stats_cleared(self, ctx: CallbackContext) -> None:
        # rl_games prints an epoch's statistics before self-play clears them: a clear that comes
        # before this epoch's after_print_stats (a callback earlier in the list) waits for it
        if self._printed_epoch == ctx.state.epoch:
            self._call("after_clear_stats")
        else:
            self._clear_pending = True


OBSERVER_METHODS = ("before_init", "after_init", "process_infos", "after_steps", "after_clear_stats",
                    "after_print_stats")


def as_callback(obj: Any) -> Callback:
    """Wrap whatever the user gave: a Callback, an AlgoObserver-like object or a function."""
    if isinstance(obj, Callback):
        return obj
    if any(hasattr(obj, name) for name in OBSERVER_METHODS):
        return AlgoObserverCallback(obj)
    if callable(obj):
        return FunctionCallback(obj)
    raise TypeError(f"{obj!r} is not a callback: subclass rlchain.training.events.Callback")


def load_callback(spec: str, source: str = "<config>", key: str = "params.config.callbacks") -> Callback:
    """``module:Name`` from the config: a class is instantiated without arguments. One that cannot be
    imported, constructed or used as a callback is a one-line ConfigError naming ``key``."""
    try:
        obj = import_object(spec)
        return as_callback(obj() if isinstance(obj, type) else obj)
    except Exception as exc:  # the user's class: any constructor error is theirs to fix, said in one line
        raise ConfigError(source, key, f"cannot use '{spec}' as a callback ({type(exc).__name__}: "
                                       f"{' '.join(str(exc).split())[:160]})") from None


def handles_env_steps(callback: Callback) -> bool:
    """Whether ``callback`` overrides ``on_env_step`` (on its class or, for adapters, the instance)."""
    return "on_env_step" in vars(callback) or type(callback).on_env_step is not Callback.on_env_step


class EnvStatsCallback(Callback):
    """Writes an env backend's counters, ``env.log_stats()`` (e.g. ``env/dropped_episodes``), every epoch."""

    def on_epoch_end(self, ctx: CallbackContext, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        for tag, value in ctx.training_env.log_stats().items():
            ctx.scalar(tag, float(value))


class CallbackList:
    """Dispatches each event to every callback in order, with the run's context first (:meth:`bind`
    sets it once the loop has built the run's parts).

    ``step_callbacks`` are the callbacks that handle ``on_env_step``: the trainers test it (an
    empty list) before doing any per-step work for them.
    """

    def __init__(self, callbacks: list[Any] | None = None) -> None:
        self.callbacks: list[Callback] = []
        self.step_callbacks: list[Callback] = []
        self.context: CallbackContext | None = None
        for callback in callbacks or []:
            self.add(callback)

    def bind(self, context: CallbackContext) -> None:
        """The context of the run whose events these are: what every callback gets first."""
        self.context = context

    def add(self, callback: Any) -> None:
        callback = as_callback(callback)
        self.callbacks.append(callback)
        if handles_env_steps(callback):
            self.step_callbacks.append(callback)

    def extend(self, callbacks: list[Any]) -> None:
        for callback in callbacks:
            self.add(callback)

    def __iter__(self):
        return iter(self.callbacks)

    def emit(self, event: str, *args: Any) -> None:
        """``event(context, *args)`` on every callback."""
        for callback in self.callbacks:
            getattr(callback, event)(self.context, *args)

    def emit_env_step(self, result: Any, done_indices: Any, rows: slice) -> None:
        """``on_env_step`` on the callbacks that handle it. One that raises is a CallbackError naming it, so the
        loop tells it from a failing env (its own exception is what the user then sees)."""
        for callback in self.step_callbacks:
            try:
                callback.on_env_step(self.context, result, done_indices, rows)
            except CallbackError:
                raise
            except Exception as exc:
                raise CallbackError(type(callback).__name__, "on_env_step", exc) from exc

    def close(self) -> None:
        """``close()`` every callback, even when one fails (reported, not raised: the run's
        own outcome or error is what the caller sees)."""
        for callback in self.callbacks:
            close = getattr(callback, "close", None)
            if not callable(close):
                continue
            try:
                close()
            except Exception as exc:  # one failed close must not keep the others open
                log.warning(f"warning: closing callback {type(callback).__name__} failed: "
                            f"{type(exc).__name__}: {exc}")
