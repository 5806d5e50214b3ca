"""The learner as it was when an update started, kept so that an update left on a stop signal can be undone
(the checkpoint then written resumes exactly). The copies go into buffers allocated once and refilled every
epoch: copying into memory already mapped costs a memcpy, a fresh deep copy also page faults."""

from __future__ import annotations

from typing import Any

import torch


class LearnerBackup:
    """``capture(learners)`` before an update; ``restore(learners)`` puts every (model, agent) pair back."""

    def __init__(self) -> None:
        self._buffers: dict[str, torch.Tensor] = {}
        self._states: list[tuple[Any, Any]] = []

    def capture(self, learners: list[tuple[torch.nn.Module, Any]]) -> None:
        self._states = [(self._mirror(model.state_dict(), f"{i}.model"), self._mirror(agent.state_dict(), f"{i}.agent"))
                        for i, (model, agent) in enumerate(learners)]

    def restore(self, learners: list[tuple[torch.nn.Module, Any]]) -> None:
        for (model, agent), (model_state, agent_state) in zip(learners, self._states):
            model.load_state_dict(model_state)
            agent.load_state_dict(agent_state)
        self._buffers.clear()  # an optimizer may keep the loaded tensors themselves: never refill those

    def _mirror(self, value: Any, path: str) -> Any:
        """``value`` with every tensor copied into this backup's buffer for ``path`` (containers rebuilt,
        other values shared: they are immutable numbers and strings, or rebuilt by the next state_dict)."""
        if isinstance(value, torch.Tensor):
            buffer = self._buffers.get(path)
            if buffer is None or buffer.shape != value.shape or buffer.dtype != value.dtype \
                    or buffer.device != value.device:
                buffer = self._buffers[path] = value.detach().clone()
            else:
                buffer.copy_(value.detach())
            return buffer
        if isinstance(value, dict):
            out = {k: self._mirror(v, f"{path}.{k}") for k, v in value.items()}
            metadata = getattr(value, "_metadata", None)  # a module state_dict's versions
            if metadata is not None:
                out = type(value)(out)
                out._metadata = metadata
            return out
        if isinstance(value, (list, tuple)):
            return type(value)(self._mirror(v, f"{path}.{i}") for i, v in enumerate(value))
        return value
