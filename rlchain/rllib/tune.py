"""The face's algorithms as Ray Tune trainables under RLlib's names: ``tune.Tuner("PPO", param_space=config)``
runs on the real Ray Tune (each trial a :class:`RLlibTrainable` that builds the algorithm from the trial's
config dict and calls ``train()`` per step). Needs ray[tune] (imported here: it is optional)."""

from __future__ import annotations

from typing import Any

from rlchain.rllib.algorithm_class import build_from_dict, without_tunes_keys
from rlchain.rllib.algorithms.registry import ALGORITHMS, config_class
from rlchain.rllib.config import AlgorithmConfig


def _trainable_base() -> type:
    try:  # optional: ray[tune]
        from ray import tune
    except ImportError as exc:
        raise ModuleNotFoundError("tune.Tuner('PPO', ...) needs Ray Tune: pip install 'ray[tune]'") from exc
    return tune.Trainable


def make_trainable(algo_name: str) -> type:
    """A Tune ``Trainable`` class that trains ``algo_name`` (PPO) through the face."""

    class RLlibTrainable(_trainable_base()):
        _algo_name = algo_name

        @classmethod
        def get_default_config(cls) -> AlgorithmConfig:
            """RLlib's ``get_trainable_cls("PPO").get_default_config()``: the algorithm's config."""
            return config_class(cls._algo_name)()

        def setup(self, config: dict[str, Any]) -> None:
            self.algo = build_from_dict(config_class(self._algo_name)(), config)

        def step(self) -> dict[str, Any]:
            return without_tunes_keys(self.algo.train())

        def save_checkpoint(self, checkpoint_dir: str) -> None:
            self.algo.save_to_path(checkpoint_dir)

        def load_checkpoint(self, checkpoint: Any) -> None:
            self.algo.restore_from_path(checkpoint)

        def cleanup(self) -> None:
            self.algo.stop()

    RLlibTrainable.__name__ = RLlibTrainable.__qualname__ = algo_name
    return RLlibTrainable


def register_trainables() -> None:
    """Register every face algorithm with Ray Tune under its RLlib name, and mark the configs as Tune's
    ``to_dict`` configs (a Tuner's ``param_space=config`` becomes ``config.to_dict()``)."""
    _trainable_base()
    from ray.tune import register_trainable  # optional: ray[tune]
    from ray.tune.tune import _Config  # optional: ray[tune]

    _Config.register(AlgorithmConfig)
    for name in ALGORITHMS:
        register_trainable(name, make_trainable(name))
