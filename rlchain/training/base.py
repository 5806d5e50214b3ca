"""Former home of the trainer base class, kept so older imports work: see :mod:`rlchain.training.loop`."""

from rlchain.training.loop import Loop, TrainResult, describe, to_device

TrainerBase = Loop
"""The name the generic loop had before it was :class:`~rlchain.training.loop.Loop`."""

__all__ = ["Loop", "TrainResult", "TrainerBase", "describe", "to_device"]
