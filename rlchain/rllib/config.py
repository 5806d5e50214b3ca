"""RLlib's ``AlgorithmConfig``: the chained builder methods, ``update_from_dict``, ``to_dict``, ``copy``,
``get``, with RLlib's key names and defaults (:mod:`rlchain.rllib.keys`).

The config is data until ``build_algo()``: :func:`rlchain.rllib.translate.rlchain_config` turns it into one
rlchain config (``{'params': ...}``) and :class:`rlchain.rllib.algorithm.Algorithm` trains it on rlchain's loop.
"""

from __future__ import annotations

import copy
import dataclasses
from typing import Any, ClassVar

from rlchain.config.errors import ConfigError
from rlchain.errors import did_you_mean
from rlchain.rllib import keys as K
from rlchain.rllib.evaluation_settings import check_evaluation
from rlchain.rllib.face_error import FaceNotOffered
from rlchain.rllib.translate import check_supported

_FROZEN = "_frozen"


class AlgorithmConfig:
    """An algorithm's settings under RLlib's names; every builder returns the config itself."""

    algo_name: ClassVar[str] = ""  # PPO, DQN, SAC, APPO, IMPALA

    def __init__(self, algo_class: Any = None) -> None:
        object.__setattr__(self, "_settings", K.defaults(self.algo_name))
        object.__setattr__(self, "_keys", K.all_keys(self.algo_name))
        object.__setattr__(self, _FROZEN, False)
        object.__setattr__(self, "algo_class", algo_class)  # RLlib's: the class given (PPOConfig's: PPO)

    @classmethod
    def overrides(cls, **kwargs: Any) -> dict[str, Any]:
        """RLlib's ``AlgorithmConfig.overrides(explore=False, ...)``: the keys checked against this config class,
        as a dict (for ``evaluation(evaluation_config=...)``); an unknown key is RLlib's KeyError."""
        keys = K.all_keys(cls.algo_name)
        out = {}
        for key, value in kwargs.items():
            name = K.OLD_NAMES.get(key, key)
            if name not in keys:
                raise KeyError(f"Invalid property name {key} for config class {cls.__name__}!"
                               f"{did_you_mean(key, keys)}")
            out[name] = value
        return out

    def get_default_learner_class(self) -> Any:
        """RLlib's Learner classes are not run by the face (one line saying what to use)."""
        raise FaceNotOffered(f"{type(self).__name__}.get_default_learner_class: RLlib's Learner classes are not run "
                             f"by rlchain's face (its loss options are config keys): train with "
                             f"config.build_algo().train()")

    # ----- setting keys -----------------------------------------------------------------------------
    def _set(self, method: str | None, values: dict[str, Any]) -> AlgorithmConfig:
        if getattr(self, _FROZEN):
            raise ConfigError(f"{type(self).__name__}", "", "this config is frozen (built into an algorithm); "
                                                            "change a copy: config.copy()")
        for key, value in values.items():
            name = K.OLD_NAMES.get(key, key)
            allowed = self._keys if method is None else _method_keys(self.algo_name, method)
            if key not in allowed and (method is not None or key not in K.OLD_NAMES):
                where = f"{type(self).__name__}.{method}()" if method else type(self).__name__
                owner = self._keys.get(key)
                if not self.algo_name and not owner:
                    raise ConfigError(where, key, _custom_algorithm(self))
                hint = f"; it belongs to .{owner}()" if owner else did_you_mean(key, allowed)
                raise ConfigError(where, key, f"not an RLlib config key{hint}")
            if name == "model_config" and dataclasses.is_dataclass(value):
                value = dataclasses.asdict(value)
            if name in ("model_config", "model") and value is not None and not isinstance(value, dict):
                raise ConfigError(type(self).__name__, key, f"expected a dict or DefaultModelConfig, got "
                                                            f"{type(value).__name__}")
            if name == "env_config":
                value = dict(value or {})
            self._settings[name] = value
        return self

    def environment(self, env: Any = None, **kwargs: Any) -> AlgorithmConfig:
        """The env: a gymnasium id, a name registered with ``ray.tune.registry.register_env`` or an env class
        built with ``env_config`` (an ``EnvContext``); ``env_config`` and RLlib's env options."""
        if env is not None:
            kwargs["env"] = env
        return self._set("environment", kwargs)

    def training(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("training", kwargs)

    def env_runners(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("env_runners", kwargs)

    def rollouts(self, **kwargs: Any) -> AlgorithmConfig:
        """RLlib's old name of :meth:`env_runners` (and its old keys: ``num_rollout_workers``...)."""
        return self._set("env_runners", kwargs)

    def learners(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("learners", kwargs)

    def resources(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("resources", kwargs)

    def evaluation(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("evaluation", kwargs)

    def reporting(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("reporting", kwargs)

    def framework(self, framework: str | None = None, **kwargs: Any) -> AlgorithmConfig:
        if framework is not None:
            kwargs["framework"] = framework
        return self._set("framework", kwargs)

    def debugging(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("debugging", kwargs)

    def multi_agent(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("multi_agent", kwargs)

    def rl_module(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("rl_module", kwargs)

    def callbacks(self, callbacks_class: Any = None, **kwargs: Any) -> AlgorithmConfig:
        """An ``RLlibCallback`` subclass (or a list of them), or single functions by event name."""
        if callbacks_class is not None:
            kwargs["callbacks_class"] = callbacks_class
        return self._set("callbacks", kwargs)

    def fault_tolerance(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("fault_tolerance", kwargs)

    def api_stack(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("api_stack", kwargs)

    def checkpointing(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("checkpointing", kwargs)

    def offline_data(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("offline_data", kwargs)

    def experimental(self, **kwargs: Any) -> AlgorithmConfig:
        return self._set("experimental", kwargs)

    def update_from_dict(self, config_dict: dict[str, Any]) -> AlgorithmConfig:
        """Set keys by RLlib name (old names and ``to_dict``'s ``lambda`` / ``input`` too); an unknown key is a
        one-line error with a did-you-mean."""
        values = dict(config_dict)
        if "multiagent" in values:  # RLlib's old nesting of the multi-agent keys
            values.update(values.pop("multiagent") or {})
        return self._set(None, values)

    # ----- reading -----------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Every key with its value, as RLlib's ``to_dict`` names them (``lambda``, ``input``, ``callbacks``)."""
        out = {}
        for key in self._keys:
            name = K.OLD_NAMES.get(key, key)
            if name != key and key not in ("lambda", "input", "callbacks"):
                continue  # an old name: its new name is listed
            out[key] = copy.deepcopy(self._settings.get(name))
        for new, old in (("lambda_", "lambda"), ("input_", "input"), ("callbacks_class", "callbacks")):
            if new in out:
                out[old] = out.pop(new)
        return out

    def get(self, key: str, default: Any = None) -> Any:
        name = K.OLD_NAMES.get(key, key)
        return self._settings.get(name, default) if name in self._keys else default

    def __getitem__(self, key: str) -> Any:
        name = K.OLD_NAMES.get(key, key)
        if name not in self._keys:
            raise KeyError(key)
        return self._settings.get(name)

    def __contains__(self, key: str) -> bool:
        return K.OLD_NAMES.get(key, key) in self._keys

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        settings = self.__dict__.get("_settings", {})
        keys = self.__dict__.get("_keys", {})
        key = K.OLD_NAMES.get(name, name)
        if key in keys or key in settings:
            return settings.get(key)
        raise AttributeError(f"{type(self).__name__} has no attribute '{name}'{did_you_mean(name, keys)}")

    def __setattr__(self, name: str, value: Any) -> None:
        if name in self.__dict__ or name == "algo_class":
            object.__setattr__(self, name, value)
        else:
            self._set(None, {name: value})

    @property
    def model_config(self) -> dict[str, Any]:
        """The resolved model settings: RLlib's DefaultModelConfig, the algorithm's defaults, an old-stack
        ``model={...}``, then ``rl_module(model_config=...)``."""
        out = dict(K.DEFAULT_MODEL)
        out.update(K.ALGO_DEFAULTS.get(self.algo_name, {}).get("model_config", {}))
        out.update(self._settings.get("model") or {})
        user = self._settings.get("model_config") or {}
        out.update(user)
        return out

    @property
    def total_train_batch_size(self) -> int:
        per_learner = self._settings.get("train_batch_size_per_learner")
        if per_learner:
            return int(per_learner) * max(1, int(self._settings.get("num_learners") or 0))
        return int(self._settings["train_batch_size"])

    def copy(self, copy_frozen: bool | None = None) -> AlgorithmConfig:
        """A deep copy (unfrozen unless ``copy_frozen`` keeps this one's state). Classes and functions in the
        config (env class, callbacks) are shared, not copied."""
        new = type(self).__new__(type(self))
        object.__setattr__(new, "_settings", {k: _copy_value(v) for k, v in self._settings.items()})
        object.__setattr__(new, "_keys", dict(self._keys))
        object.__setattr__(new, _FROZEN, bool(copy_frozen) and getattr(self, _FROZEN))
        object.__setattr__(new, "algo_class", self.algo_class)
        return new

    def freeze(self) -> None:
        object.__setattr__(self, _FROZEN, True)

    def validate(self) -> None:
        """Refuse, in one line each, the settings the face does not offer (see :data:`keys.UNSUPPORTED`) and those
        RLlib's own validation refuses (:mod:`rlchain.rllib.evaluation_settings`)."""
        check_supported(self)
        check_evaluation(self)

    # ----- building ----------------------------------------------------------------------------------
    def build_algo(self, env: Any = None, logger_creator: Any = None, use_copy: bool = True) -> Any:
        """The Algorithm of this config on rlchain's loop (``env``: sets the env first, as RLlib's)."""
        if self.algo_class is None:
            raise ConfigError(type(self).__name__, "algo_class", "no algorithm to build: use PPOConfig / DQNConfig")
        config = self.copy() if use_copy else self
        if env is not None:
            config.environment(env)
        return self.algo_class(config=config)

    def build(self, env: Any = None, logger_creator: Any = None, use_copy: bool = True) -> Any:
        """RLlib's older name of :meth:`build_algo`."""
        return self.build_algo(env, logger_creator, use_copy)

    def __repr__(self) -> str:
        changed = {k: v for k, v in self._settings.items() if v != K.defaults(self.algo_name).get(k)}
        return f"{type(self).__name__}({changed})"


def _method_keys(algo: str, method: str) -> tuple[str, ...]:
    """The keyword names builder ``method`` of ``algo``'s config takes."""
    return K.METHOD_KEYS[method] + (K.ALGO_TRAINING_KEYS.get(algo, ()) if method == "training" else ())


def _custom_algorithm(config: AlgorithmConfig) -> str:
    """Why a key of a user's own ``AlgorithmConfig`` subclass (a new algorithm, as RLlib's VPG example) is refused."""
    algo = getattr(config.algo_class, "__name__", None) or "its Algorithm"
    return (f"a key of a custom algorithm's config: a new Algorithm ({algo}, with its own training_step, Learner and "
            f"RLModule) is not run by rlchain's face, which trains PPO, APPO, IMPALA, DQN and SAC: start from "
            f"PPOConfig() or another of those")


def _copy_value(value: Any) -> Any:
    if isinstance(value, type) or callable(value):
        return value
    try:
        return copy.deepcopy(value)
    except Exception:  # an object that does not copy (an env instance...): shared
        return value
