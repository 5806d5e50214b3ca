"""YAML or JSON file -> dict -> ``key.path=value`` overrides -> typed :class:`Params`.

Every error is a :class:`ConfigError` naming the file, the key path and what was expected.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import os
from typing import Any

import yaml

from rlchain.config import compat, embodichain
from rlchain.config.actor_critic import check_batch  # noqa: F401  (importable from here too)
from rlchain.config.algo_keys import config_class_of, drop_other_algo_keys
from rlchain.config.errors import ConfigError
from rlchain.config.fields import parse_dataclass, parse_value
from rlchain.config.multi_agent import KEY, RUN_LEVEL_KEYS, PolicySpec, check_multi_agent
from rlchain.config.network import NetworkConfig, ResnetNetworkConfig
from rlchain.config.network_block import check_planned, check_registered, network_name, parse_network
from rlchain.config.params import NamedBlock, Params
from rlchain.config.text import MAX_NESTING, AliasFound, NoAliasLoader, nesting, read_data
from rlchain.errors import did_you_mean
from rlchain.registry import ALGOS, MODELS, NETWORKS, import_object


def check_malloc(value: str) -> str | None:
    """``params.malloc``: keep or default (rlchain.parallel.memory)."""
    return None if value in ("keep", "default") else f"expected keep or default, got {value!r}"


SEED_RANGE = 2**32
"""Seeds are 0 .. 2**32 - 1: what numpy's and gymnasium's generators take."""


def check_seed(value: int) -> str | None:
    return None if 0 <= value < SEED_RANGE else "must be in 0 .. 2**32 - 1"


def load_raw(path: str) -> dict[str, Any]:
    """Read a YAML or JSON config file into a dict (``.json`` is JSON, anything else YAML, aliases refused)."""
    if not os.path.isfile(path):
        raise ConfigError(path, "", "config file not found")
    data = read_data(path)
    if not isinstance(data, dict):
        raise ConfigError(path, "", "expected a mapping with a top-level 'params' key")
    return data


def apply_overrides(raw: dict[str, Any], overrides: list[str], source: str, prefix: str | None = "params"
                    ) -> dict[str, Any]:
    """Apply ``a.b.c=value`` overrides (value parsed as YAML); a leading ``params.`` (``prefix``) is optional.
    ``prefix`` None: the keys as given (``trainer.gym_config=Name`` on an EmbodiChain dict)."""
    import copy

    out = copy.deepcopy(raw)
    for item in overrides:
        if "=" not in item:
            raise ConfigError(source, item, "override must look like key.path=value")
        key, text = item.split("=", 1)
        parts = key.strip().split(".")
        if prefix is not None and parts[0] != prefix:
            parts = [prefix, *parts]
        if nesting(text) > MAX_NESTING:
            raise ConfigError(source, key.strip(), f"the value nests more than {MAX_NESTING} levels deep")
        try:
            value = yaml.load(text, Loader=NoAliasLoader)  # noqa: S506
        except AliasFound as exc:
            raise ConfigError(source, key.strip(), str(exc)) from None
        except yaml.YAMLError:
            value = text
        node = out
        for i, part in enumerate(parts[:-1]):
            child = node.get(part)
            if child is None:
                child = node[part] = {}
            if not isinstance(child, dict):
                raise ConfigError(source, ".".join(parts[: i + 1]), "override goes through a non-mapping key")
            node = child
        node[parts[-1]] = value
    return out


def from_embodichain(raw: dict[str, Any], overrides: list[str], source: str) -> tuple[dict[str, Any], list[str]]:
    """An EmbodiChain ``train_config`` (``trainer`` / ``policy`` / ``algorithm``) as rlchain's ``{'params': ...}``
    dict, with the overrides on its own keys (``trainer.seed=3``) applied first; returns it and the other
    overrides (``params.*``, applied by the caller). Any other dict comes back as it is. The
    ``params.import_modules`` overrides are imported first: they register the envs ``gym_config`` names."""
    if not embodichain.is_embodichain(raw):
        return raw, overrides
    ours, rest = embodichain.split_overrides(overrides)
    import_user_modules(apply_overrides({"params": {}}, [o for o in rest if "import_modules=" in o], source),
                        source)
    return embodichain.translate(apply_overrides(raw, ours, source, prefix=None), source), rest


def parse_params(raw: dict[str, Any], source: str = "<config>") -> Params:
    """Validate a whole config dict and return typed :class:`Params`."""

    if "params" not in raw:
        raise ConfigError(source, "params", "required top-level key is missing")
    extra = [k for k in raw if k != "params"]
    if extra:
        raise ConfigError(source, extra[0], "unknown top-level key; everything goes under 'params'")
    params = raw["params"]
    if not isinstance(params, dict):
        raise ConfigError(source, "params", f"expected a mapping, got {params!r}")
    params = compat.translate_params(params, source)
    known = {"seed", "algo", "model", "network", "config", "import_modules", "torch_threads", "update_threads",
             "malloc"}
    for key in params:
        if key not in known:
            hint = did_you_mean(key, sorted(known), n=1) or f"; known keys: {', '.join(sorted(known))}"
            raise ConfigError(source, f"params.{key}", f"unknown key{hint}")
    for key in ("algo", "model", "config"):
        if key not in params:
            raise ConfigError(source, f"params.{key}", "required key is missing")

    # imported by the Runner before parsing (import_user_modules): they register what the checks below look up
    modules = parse_value(list[str], params.get("import_modules") or [], "params.import_modules", source)

    seed = parse_value(int | None, params.get("seed"), "params.seed", source, {"check": check_seed})
    threads = parse_value(int | None, params.get("torch_threads"), "params.torch_threads", source,
                          {"check": lambda x: None if x > 0 else "must be > 0"})
    update_threads = parse_value(int | None, params.get("update_threads"), "params.update_threads", source,
                                 {"check": lambda x: None if x > 0 else "must be > 0"})
    malloc = parse_value(str, params.get("malloc", "keep"), "params.malloc", source, {"check": check_malloc})
    algo = parse_dataclass(NamedBlock, params["algo"], "params.algo", source)
    old_model_name = params["model"].get("name") if isinstance(params["model"], dict) else None
    model = parse_dataclass(NamedBlock, compat.translate_model(params["model"], source), "params.model", source)
    check_registered(ALGOS, algo.name, "params.algo.name", source)
    check_registered(MODELS, model.name, "params.model.name", source)

    config_raw = params["config"]
    if not isinstance(config_raw, dict):
        raise ConfigError(source, "params.config", f"expected a mapping, got {config_raw!r}")
    # each algorithm declares its own config dataclass (config_class); PPO's is PPOConfig
    config_class = config_class_of(algo.name)
    config_raw = compat.translate_config(config_raw, source)
    config_raw = drop_other_algo_keys(config_raw, algo.name, source)  # another algo's key: a warning
    config = parse_dataclass(config_class, config_raw, "params.config", source)
    check_planned(config, "params.config", source)
    config = _checked(config, source)
    _check_callbacks(config.callbacks, source)

    network = parse_network(params.get("network"), source)
    check_registered(NETWORKS, network_name(network), "params.network.name", source)
    if isinstance(network, (NetworkConfig, ResnetNetworkConfig)):
        compat.check_model_alias(old_model_name, network.rnn is not None, source)
    if isinstance(network, NetworkConfig) and network.central_value:
        raise ConfigError(source, "params.network.central_value", "True makes a value-only critic, but "
                          "params.network is the actor; put the critic under config.central_value_config.network")
    config = config.with_network(network, source)  # the config's own checks against the network (PPO: RNN)
    out = Params(algo=algo, model=model, config=config, network=network, seed=seed,
                 import_modules=modules, torch_threads=threads, update_threads=update_threads,
                 malloc=malloc, source=source)
    if getattr(config, "multi_agent", None) is not None:  # PPO's config.multi_agent: a Params per policy
        out = dataclasses.replace(out, policies=_policy_params(out, params, source))
    return out


def _checked(config: Any, source: str) -> Any:
    """The config's own checks (each algorithm's class: :meth:`~rlchain.config.run.RunConfig.resolved`,
    then :meth:`~rlchain.config.run.RunConfig.validate`); returns it with its derived values."""
    config = config.resolved(source)
    problem = config.validate()
    if problem:
        key, message = problem
        raise ConfigError(source, f"params.config.{key}", message)
    return config


def import_user_modules(raw: Any, source: str = "<config>") -> list[str]:
    """Import the config's ``params.import_modules`` (user packages that register networks, models, algos
    and envs) and return their names; a module that cannot be imported is a one-line ConfigError. Run it
    before :func:`parse_params`, which looks those registrations up (``Runner.load`` does)."""
    params = raw.get("params") if isinstance(raw, dict) else None
    if not isinstance(params, dict) or params.get("import_modules") is None:
        return []
    modules = parse_value(list[str], params["import_modules"], "params.import_modules", source)
    for name in modules:
        try:
            importlib.import_module(name)
        except ImportError as exc:
            raise ConfigError(source, "params.import_modules", f"cannot import '{name}': {exc}") from None
    return modules


def _policy_params(top: Params, raw_params: dict, source: str) -> dict[str, Params]:
    """``config.multi_agent``: each policy's own Params -- the top-level network, model and config with
    the policy's ``network`` / ``model`` / ``config`` in their place (see rlchain/config/multi_agent.py)."""

    ma = top.config.multi_agent
    names = check_multi_agent(ma, source)
    base = drop_other_algo_keys(compat.translate_config(raw_params["config"], source), top.algo.name, source,
                                warn=False)  # warned about once already, as params.config
    base.pop("multi_agent", None)
    out = {}
    for name in names:
        path = f"{KEY}.policies.{name}"
        spec = parse_dataclass(PolicySpec, ma.policies.get(name) or {}, path, source)
        for key in spec.config:
            if key in RUN_LEVEL_KEYS:
                raise ConfigError(source, f"{path}.config.{key}", "is a run-level key: set it at params.config")
        merged = {**base, **drop_other_algo_keys(compat.translate_config(spec.config, source), top.algo.name, source,
                                                 f"{path}.config")}
        if "minibatch_size" in spec.config:
            merged.pop("minibatch_size_per_env", None)
        config = parse_dataclass(type(top.config), merged, f"{path}.config", source).resolved(source)
        network = top.network if spec.network is None else parse_network(spec.network, source, f"{path}.network")
        check_registered(NETWORKS, network_name(network), f"{path}.network.name", source)
        model = top.model if spec.model is None else parse_dataclass(
            NamedBlock, compat.translate_model(spec.model, source), f"{path}.model", source)
        check_registered(MODELS, model.name, f"{path}.model.name", source)
        out[name] = Params(algo=top.algo, model=model, config=config, network=network, seed=top.seed,
                           torch_threads=top.torch_threads, update_threads=top.update_threads, malloc=top.malloc,
                           source=source)
    return out


def load_config(path: str, overrides: list[str] | None = None) -> Params:
    """Read, override, import ``params.import_modules`` and validate a config file in one call (what
    ``Runner.load`` does with a path)."""
    raw, overrides = from_embodichain(load_raw(path), overrides or [], path)
    raw = apply_overrides(raw, overrides, path)
    import_user_modules(raw, path)
    return parse_params(raw, path)


def _check_callbacks(specs: list[str], source: str) -> None:
    """Each ``package.module:Name`` in config.callbacks must import."""
    for i, spec in enumerate(specs):
        path = f"params.config.callbacks[{i}]"
        try:
            obj = import_object(spec)
        except ValueError as exc:
            raise ConfigError(source, path, str(exc)) from None
        if isinstance(obj, type):  # built with no arguments: say so now, not after the run folder exists
            try:
                inspect.signature(obj).bind()
            except TypeError as exc:
                raise ConfigError(source, path, f"'{spec}' cannot be built without arguments ({exc}); a callback "
                                                f"class takes none") from None
            except ValueError:  # no signature to read (a builtin): its construction says it, in one line
                pass
        elif inspect.isfunction(obj) or inspect.isbuiltin(obj):  # called as fn(ctx, stats, episodes)
            try:
                inspect.signature(obj).bind(None, None, None)
            except TypeError as exc:
                raise ConfigError(source, path, f"'{spec}' cannot be called as fn(ctx, stats, episodes) ({exc})") \
                    from None
            except ValueError:
                pass
