"""The face's algorithm classes as RLlib users pass them around: ``PPO`` (and ``config.algo_class``, the same
object, as in RLlib: ``PPOConfig().algo_class is PPO``).

RLlib's ``Algorithm`` is a Ray Tune ``Trainable``, so RLlib's docs hand ``config.algo_class`` to
``tune.Tuner(config.algo_class, param_space=config)``. The face's algorithms are not Trainables (rlchain does not
need Ray), and Tune takes a class only when it is one; it takes any callable of one ``config`` argument as a
function trainable. So the name the face exports (``PPO``, ``DQN``, ...) is an :class:`AlgorithmClass`, the
algorithm class as that callable: given an AlgorithmConfig (``PPO(config=...)``, what ``build_algo`` calls) it
builds the algorithm; given Tune's trial config dict it runs the trial (:func:`run_trial`). Otherwise it stands
for the class: its attributes (``get_default_config()``, ``from_checkpoint()``), ``isinstance(algo, PPO)``,
``class MyPPO(PPO)`` and pickling work as for the class; ``inspect.isclass(PPO)`` and ``issubclass(PPO, ...)``
do not (the class itself is ``PPO.cls``).
"""

from __future__ import annotations

import tempfile
from typing import Any, ClassVar


class AlgorithmClass:
    """The face's algorithm class ``cls``, callable as RLlib's and as a Tune function trainable (one per class:
    :meth:`of`)."""

    _made: ClassVar[dict[type, AlgorithmClass]] = {}

    def __init__(self, cls: type) -> None:
        self.cls = cls
        self.__name__ = self.__qualname__ = cls.__name__
        self.__doc__ = cls.__doc__
        self.__module__ = cls.__module__

    @classmethod
    def of(cls, algo: type) -> AlgorithmClass:
        """The one AlgorithmClass of class ``algo`` (so ``config.algo_class is PPO`` holds after a copy or a
        pickle round trip)."""
        if algo not in cls._made:
            cls._made[algo] = cls(algo)
        return cls._made[algo]

    def __instancecheck__(self, obj: object) -> bool:
        return isinstance(obj, self.cls)

    def __subclasscheck__(self, sub: Any) -> bool:
        return issubclass(sub.cls if isinstance(sub, AlgorithmClass) else sub, self.cls)

    def __mro_entries__(self, bases: tuple[Any, ...]) -> tuple[type, ...]:
        return (self.cls,)  # ``class MyPPO(PPO)`` subclasses the class itself

    def __reduce__(self) -> tuple[Any, ...]:
        return AlgorithmClass.of, (self.cls,)

    def __call__(self, config: Any) -> Any:
        if isinstance(config, dict):  # a Tune trial's config
            return run_trial(self.cls, config)
        return self.cls(config=config)

    def default_resource_request(self, config: Any) -> Any:
        """What a Tune trial of this algorithm asks Ray for (``tune.with_resources(fn, resources=...)``): one bundle
        of ``num_cpus_for_main_process`` CPUs and the learners' GPUs (:func:`trial_gpus`), since the face steps a
        trial's envs and trains in the trial's own process (RLlib adds a bundle per env runner and learner)."""
        from ray import tune  # optional: ray[tune]

        get = config.get if hasattr(config, "get") else dict(config).get
        bundle = {"CPU": get("num_cpus_for_main_process", 1) or 1}
        if trial_gpus(get):
            bundle["GPU"] = trial_gpus(get)
        return tune.PlacementGroupFactory([bundle])

    def __getattr__(self, name: str) -> Any:
        if name == "cls" or name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.cls, name)

    def __eq__(self, other: object) -> bool:
        return other is self.cls or (isinstance(other, AlgorithmClass) and other.cls is self.cls)

    def __hash__(self) -> int:
        return hash(self.cls)

    def __repr__(self) -> str:
        return f"<class '{self.__module__}.{self.__name__}'>"


def trial_gpus(get: Any) -> float:
    """The GPUs a trial asks for, as RLlib 2.60 counts them (``get``: the config's lookup): on the new API stack its
    learners' (``num_gpus_per_learner`` for the local learner or each of ``num_learners``; ``num_gpus`` is an old
    stack key there, so ``fractional_gpus.py``'s ``num_gpus=0.5`` asks for none), ``num_gpus`` on the old stack."""
    def number(key: str) -> float:
        value = get(key, 0)
        return value if isinstance(value, (int, float)) and not isinstance(value, bool) else 0

    if get("enable_rl_module_and_learner", True) is False:
        return number("num_gpus")
    return number("num_gpus_per_learner") * max(number("num_learners"), 1)


def exported(cls: type) -> AlgorithmClass:
    """The name a face algorithm module exports for its class ``cls`` (``PPO = exported(PPO)``): its
    AlgorithmClass, with the class reachable by reference as ``<module>.PPO.cls`` (so pickle finds it)."""
    cls.__qualname__ = f"{cls.__qualname__}.cls"
    return AlgorithmClass.of(cls)


def build_from_dict(algo_config: Any, config: dict[str, Any]) -> Any:
    """The algorithm of ``algo_config`` (an algorithm's default config) updated with a trial's config dict (Tune's
    ``param_space=config`` arrives as ``config.to_dict()``; keys the config does not have are Tune's)."""
    algo_config.update_from_dict({k: v for k, v in config.items() if k in algo_config})
    return algo_config.build_algo()


def without_tunes_keys(result: dict[str, Any]) -> dict[str, Any]:
    """A ``train()`` result without the keys Tune adds itself."""
    for key in ("training_iteration", "done", "time_this_iter_s", "time_total_s", "timestamp",
                "iterations_since_restore"):
        result.pop(key, None)
    return result


def run_trial(cls: type, config: dict[str, Any]) -> None:
    """One Tune trial of algorithm class ``cls`` as a function trainable: ``train()`` until Tune stops it, each
    result reported with a checkpoint of the algorithm (so ``result.checkpoint`` is the last); a restarted trial
    resumes from its last checkpoint."""
    from ray import tune  # optional: ray[tune]

    algo = build_from_dict(cls.get_default_config(), config)
    try:
        checkpoint = tune.get_checkpoint()
        if checkpoint is not None:
            with checkpoint.as_directory() as folder:
                algo.restore_from_path(folder)
        while True:
            result = without_tunes_keys(algo.train())
            with tempfile.TemporaryDirectory() as folder:
                algo.save_to_path(folder)
                tune.report(result, checkpoint=tune.Checkpoint.from_directory(folder))
    finally:
        algo.stop()
