"""``config.events`` (EmbodiChain's ``trainer.events``) as callbacks: a user function every N training env
steps or after every N-th in-training evaluation, and ``video`` (EmbodiChain's ``record_camera_data``)
as rlchain's video of evaluation episodes. EmbodiChain parses its train events and never applies them;
here both phases run."""

from __future__ import annotations

from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.envs.vecenv import VecEnv
from rlchain.log import get_logger
from rlchain.policy.recording import gym_id_of
from rlchain.registry import import_object
from rlchain.training.callback_context import CallbackContext
from rlchain.training.events import Callback
from rlchain.training.video_callback import VideoCallback

log = get_logger(__name__)


def _function(spec: str, source: str) -> Any:
    try:
        fn = import_object(spec)
    except ValueError as exc:
        raise ConfigError(source, "params.config.events", f"cannot load function '{spec}': {exc}") from None
    if not callable(fn):
        raise ConfigError(source, "params.config.events", f"'{spec}' is not callable")
    return fn


def _user_env(env: VecEnv) -> Any:
    """The EmbodiChain-contract env behind rlchain's adapter (rlchain.envs.backends.embodichain_env), else env."""
    return env.__dict__.get("env", env) if type(env).__name__ == "EmbodiChainVecEnv" else env


class TrainEvent(Callback):
    """Calls ``fn(env, env_ids=None, **params)`` every ``interval_step`` training env steps."""

    def __init__(self, fn: Any, every: int, params: dict) -> None:
        self.fn, self.every, self.params, self.steps = fn, every, params, 0

    def on_env_step(self, ctx: CallbackContext, result: Any, done_indices: Any, rows: slice) -> None:
        if rows.start not in (None, 0):  # a pipelined rollout calls once per env group: count the step once
            return
        self.steps += 1
        if self.steps % self.every == 0:
            self.fn(_user_env(ctx.training_env), None, **self.params)


class EvalEvent(Callback):
    """Calls ``fn(env, env_ids=None, **params)`` after every ``interval_step``-th in-training evaluation."""

    def __init__(self, fn: Any, every: int, params: dict) -> None:
        self.fn, self.every, self.params, self.count = fn, every, params, 0

    def on_evaluation(self, ctx: CallbackContext, result: Any) -> None:
        self.count += 1
        if self.count % self.every == 0:
            self.fn(_user_env(ctx.training_env), None, **self.params)


def event_callbacks(events: list[Any], evaluation_on: bool, params: Any) -> list[Callback]:
    """The callbacks of ``config.events``; ``video`` needs moviepy and an env that renders (a warning and no
    video otherwise, so an EmbodiChain config with a camera event still trains on a tensor env)."""
    out: list[Callback] = []
    source = params.source
    for event in events:
        if event.func == "video":
            if not evaluation_on:
                continue
            try:
                gym_id_of(params)  # a gymnasium env renders; a tensor env does not
                out.append(VideoCallback(event.interval_step, event.params.get("save_path")))
            except (ImportError, ConfigError) as exc:
                log.warning(f"{source}: params.config.events: video of evaluation episodes skipped ({exc})")
            continue
        fn = _function(event.func, source)
        cls = TrainEvent if event.phase == "train" else EvalEvent
        out.append(cls(fn, event.interval_step, dict(event.params)))
    return out
