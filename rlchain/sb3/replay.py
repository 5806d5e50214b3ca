"""SB3's ``model.replay_buffer``, ``save_replay_buffer`` and ``load_replay_buffer`` for SAC and DQN.

After ``learn`` the model keeps the run's replay buffer contents (:class:`ReplayBufferView`: ``size()``, ``pos``,
``full``, ``buffer_size`` as SB3's buffer has them); ``save_replay_buffer(path)`` writes them (tensors only, read
back as data by :mod:`rlchain.runs.checkpoint`), ``load_replay_buffer(path)`` reads them and the next ``learn``
starts its run with them. The file is rlchain's (SB3's replay-buffer pickles are not read: they hold objects).
"""

from __future__ import annotations

import os
from typing import Any

from rlchain.runs import checkpoint as ckpt
from rlchain.training.callback_context import CallbackContext
from rlchain.training.events import Callback

FORMAT = "rlchain-sb3-replay-1"


class ReplayBufferView:
    """The contents of a replay buffer: ``state`` (rlchain's ``ReplayBuffer.state_dict()``, empty when None), or
    while a run goes its ``live`` buffer (a callback's ``save_replay_buffer`` during ``learn`` saves it as it is)."""

    def __init__(self, capacity: int, state: dict[str, Any] | None = None, live: Any = None) -> None:
        self.buffer_size = int(capacity)
        self._state = state
        self.live = live

    @property
    def state(self) -> dict[str, Any] | None:
        if self.live is not None:
            return self.live.state_dict() if self.live.size else None
        return self._state

    def size(self) -> int:
        """Transitions held (SB3's ``replay_buffer.size()``)."""
        if self.live is not None:
            return int(self.live.size)
        return 0 if self._state is None else int(self._state["size"])

    @property
    def pos(self) -> int:
        if self.live is not None:
            return int(self.live.pos)
        return 0 if self._state is None else int(self._state["pos"])

    @property
    def full(self) -> bool:
        return self.size() >= self.buffer_size


def replay_path(path: str) -> str:
    """``path``, with ``.pkl`` added when it has no extension (as SB3 names its replay buffer files)."""
    path = os.fspath(path)
    return path if os.path.splitext(path)[1] else path + ".pkl"


def save_replay(view: ReplayBufferView, path: str) -> str:
    """Write ``view``'s contents to ``path`` (see :func:`replay_path`); returns the path."""
    if view.state is None:
        raise ValueError(f"{path}: the replay buffer is empty (learn first, or load_replay_buffer)")
    path = replay_path(path)
    ckpt.save_atomic({"format": FORMAT, "capacity": view.buffer_size, "buffer": view.state}, path)
    return path


def load_replay(path: str, capacity: int) -> ReplayBufferView:
    """A :class:`ReplayBufferView` of a file :func:`save_replay` wrote, read as data."""
    path = replay_path(path)
    state = ckpt.read(path)
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        raise ValueError(f"{path}: not a replay buffer saved by rlchain's save_replay_buffer")
    if int(state["capacity"]) != capacity:
        raise ValueError(f"{path}: a replay buffer of {state['capacity']} transitions, the model's holds {capacity} "
                         f"(buffer_size)")
    return ReplayBufferView(capacity, state["buffer"])


class ReplayCallback(Callback):
    """Puts the model's replay buffer contents into the run's buffer at the start, and takes them back at the
    end (the buffer is the run's algorithm's: ``ctx.algorithm.buffer``)."""

    def __init__(self, model: Any) -> None:
        self.model = model

    def on_train_start(self, ctx: CallbackContext) -> None:
        view, buffer = self.model.replay_buffer, ctx.algorithm.buffer
        if view is not None and view.state is not None and buffer.size == 0:
            buffer.load_state_dict(view.state)
        self.model.replay_buffer = ReplayBufferView(buffer.capacity, live=buffer)

    def on_train_end(self, ctx: CallbackContext, result: Any) -> None:
        buffer = ctx.algorithm.buffer
        self.model.replay_buffer = ReplayBufferView(buffer.capacity, buffer.state_dict())
