"""``config.algo_class``: the face's algorithm class as RLlib users pass it around.

RLlib's ``Algorithm`` is a Ray Tune ``Trainable``, so RLlib's docs hand ``config.algo_class`` to
``tune.Tuner(config.algo_class, param_space=config)``. The face's algorithms are not Trainables (rlchain does not
need Ray), and Tune takes a class only when it is one; it takes any callable of one ``config`` argument as a
function trainable. So ``config.algo_class`` is this callable: given an AlgorithmConfig (``algo_class(config=...)``,
what ``build_algo`` calls) it builds the algorithm; given Tune's trial config dict it runs the trial
(:func:`rlchain.rllib.tune.run_trial`). Other attributes are the class's (``get_default_config()``...).
"""

from __future__ import annotations

from typing import Any


class AlgorithmClass:
    """The face's algorithm class ``cls``, callable as RLlib's and as a Tune function trainable."""

    def __init__(self, cls: type) -> None:
        self.cls = cls
        self.__name__ = self.__qualname__ = getattr(cls, "algo_name", "") or cls.__name__
        self.__doc__ = cls.__doc__

    def __call__(self, config: Any) -> Any:
        if isinstance(config, dict):  # a Tune trial's config
            from rlchain.rllib.tune import run_trial  # optional: ray[tune]

            return run_trial(self.__name__, config)
        return self.cls(config=config)

    def __getattr__(self, name: str) -> Any:
        if name == "cls":
            raise AttributeError(name)
        return getattr(self.cls, name)

    def __eq__(self, other: object) -> bool:
        return other is self.cls or (isinstance(other, AlgorithmClass) and other.cls is self.cls)

    def __hash__(self) -> int:
        return hash(self.cls)

    def __repr__(self) -> str:
        return f"<algo_class {self.cls.__module__}.{self.cls.__qualname__}>"
