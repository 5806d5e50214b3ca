"""What the face adds to Ray Tune's own modules as they load (under ``python -m rlchain.rllib``; :mod:`.alias`).

- ``ray.tune.tune``: the face's AlgorithmConfig is a Tune ``_Config``, so ``tune.Tuner("PPO", param_space=config)``
  reads ``config.to_dict()``, as for RLlib's configs;
- ``ray.tune.impl.tuner_internal``: ``tune.Tuner(config.algo_class, ...)`` whose ``RunConfig`` asks for
  checkpoints (``CheckpointConfig(checkpoint_at_end=True)`` or a ``checkpoint_frequency``) trains the algorithm's
  Trainable class (:func:`rlchain.rllib.tune.make_trainable`, what ``tune.Tuner("APPO", ...)`` runs), as RLlib's
  Algorithm is a Trainable class; Tune refuses both settings for the function trainable the face's algorithm
  class otherwise is (which reports a checkpoint with every result instead).
"""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType
from typing import Any

from rlchain.rllib.algorithm_class import AlgorithmClass
from rlchain.rllib.config import AlgorithmConfig
from rlchain.rllib.tune import make_trainable


def register_config(module: ModuleType) -> None:
    module._Config.register(AlgorithmConfig)


def wants_checkpoints(run_config: Any) -> bool:
    """Whether a Tune ``RunConfig`` asks Tune itself for checkpoints (a function trainable may not)."""
    checkpoint = getattr(run_config, "checkpoint_config", None)
    return bool(getattr(checkpoint, "checkpoint_at_end", False) or getattr(checkpoint, "checkpoint_frequency", 0))


def trainable_for(trainable: Any, run_config: Any) -> Any:
    """The trainable Tune gets for ``trainable``: the Trainable class of a face algorithm class whose run asks
    for checkpoints, else ``trainable`` itself."""
    if isinstance(trainable, AlgorithmClass) and wants_checkpoints(run_config):
        return make_trainable(trainable.cls.algo_name)
    return trainable


def checkpointing_algorithm_classes(module: ModuleType) -> None:
    convert = module.TunerInternal._convert_trainable

    def _convert_trainable(self: Any, trainable: Any) -> Any:
        return convert(self, trainable_for(trainable, getattr(self, "_run_config", None)))

    module.TunerInternal._convert_trainable = _convert_trainable


HOOKS: dict[str, Callable[[ModuleType], None]] = {
    "ray.tune.tune": register_config,
    "ray.tune.impl.tuner_internal": checkpointing_algorithm_classes,
}
"""Ray Tune's module -> what runs on it once it has loaded."""
