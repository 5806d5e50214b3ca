"""YAML or JSON file -> dict -> ``key.path=value`` overrides -> typed :class:`Params`.

Every error is a :class:`ConfigError` naming the file, the key path and what was expected.
"""

from __future__ import annotations

import dataclasses
import importlib
import json
import os
from typing import Any

import yaml

from rlchain.config import compat, embodichain
from rlchain.config.actor_critic import ActorCriticConfig
from rlchain.config.algo_keys import config_class_of, drop_other_algo_keys
from rlchain.config.errors import ConfigError
from rlchain.config.fields import parse_dataclass, parse_value
from rlchain.config.multi_agent import KEY, RUN_LEVEL_KEYS, PolicySpec, check_multi_agent
from rlchain.config.schema import (
    CentralValueConfig,
    NamedBlock,
    NetworkConfig,
    Params,
    ResnetNetworkConfig,
    TrainConfig,
)
from rlchain.registry import ALGOS, MODELS, NETWORKS, network_config_class


def check_malloc(value: str) -> str | None:
    """``params.malloc``: keep or default (rlchain.parallel.memory)."""
    return None if value in ("keep", "default") else f"expected keep or default, got {value!r}"


def load_raw(path: str) -> dict[str, Any]:
    """Read a YAML or JSON config file into a dict (``.json`` is JSON, anything else YAML)."""
    if not os.path.isfile(path):
        raise ConfigError(path, "", "config file not found")
    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    try:
        data = json.loads(text) if path.endswith(".json") else yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError) as exc:
        detail = " ".join(str(exc).split())
        raise ConfigError(path, "", f"cannot parse file: {detail}") from None
    if not isinstance(data, dict):
        raise ConfigError(path, "", "expected a mapping with a top-level 'params' key")
    return data


def apply_overrides(raw: dict[str, Any], overrides: list[str], source: str) -> dict[str, Any]:
    """Apply ``a.b.c=value`` overrides (value parsed as YAML); a leading ``params.`` is optional."""
    import copy

    out = copy.deepcopy(raw)
    for item in overrides:
        if "=" not in item:
            raise ConfigError(source, item, "override must look like key.path=value")
        key, text = item.split("=", 1)
        parts = key.strip().split(".")
        if parts[0] != "params":
            parts = ["params", *parts]
        try:
            value = yaml.safe_load(text)
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
    return embodichain.translate(embodichain.apply_overrides(raw, ours, source), source), rest


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
            import difflib
            close = difflib.get_close_matches(key, sorted(known), n=1)
            hint = f"; did you mean '{close[0]}'?" if close else f"; known keys: {', '.join(sorted(known))}"
            raise ConfigError(source, f"params.{key}", f"unknown key{hint}")
    for key in ("algo", "model", "config"):
        if key not in params:
            raise ConfigError(source, f"params.{key}", "required key is missing")

    # imported by the Runner before parsing (import_user_modules): they register what the checks below look up
    modules = parse_value(list[str], params.get("import_modules") or [], "params.import_modules", source)

    seed = parse_value(int | None, params.get("seed"), "params.seed", source)
    threads = parse_value(int | None, params.get("torch_threads"), "params.torch_threads", source,
                          {"check": lambda x: None if x > 0 else "must be > 0"})
    update_threads = parse_value(int | None, params.get("update_threads"), "params.update_threads", source,
                                 {"check": lambda x: None if x > 0 else "must be > 0"})
    malloc = parse_value(str, params.get("malloc", "keep"), "params.malloc", source, {"check": check_malloc})
    algo = parse_dataclass(NamedBlock, params["algo"], "params.algo", source)
    old_model_name = params["model"].get("name") if isinstance(params["model"], dict) else None
    model = parse_dataclass(NamedBlock, compat.translate_model(params["model"], source), "params.model", source)
    _check_registered(ALGOS, algo.name, "params.algo.name", source)
    _check_registered(MODELS, model.name, "params.model.name", source)

    config_raw = params["config"]
    if not isinstance(config_raw, dict):
        raise ConfigError(source, "params.config", f"expected a mapping, got {config_raw!r}")
    # each algorithm declares its own config dataclass (config_class); PPO's is TrainConfig
    config_class = config_class_of(algo.name)
    config_raw = compat.translate_config(config_raw, source)
    config_raw = drop_other_algo_keys(config_raw, algo.name, source)  # another algo's key: a warning
    config = parse_dataclass(config_class, config_raw, "params.config", source)
    _check_planned(config, "params.config", source)
    if isinstance(config, ActorCriticConfig):  # PPO, appo, impala: minibatches, lr schedules
        config = _resolve_training(config, source)
    validate = getattr(config, "validate", None)
    if validate is not None:
        problem = validate()
        if problem:
            key, message = problem
            raise ConfigError(source, f"params.config.{key}", message)
    _check_callbacks(config.callbacks, source)

    network = _parse_network(params.get("network"), source)
    _check_registered(NETWORKS, _network_name(network), "params.network.name", source)
    if isinstance(network, (NetworkConfig, ResnetNetworkConfig)):
        compat.check_model_alias(old_model_name, network.rnn is not None, source)
    if isinstance(config, TrainConfig) and isinstance(network, (NetworkConfig, ResnetNetworkConfig)) \
            and network.rnn is not None:
        _check_sequences(config, source)
    if isinstance(network, NetworkConfig) and network.central_value:
        raise ConfigError(source, "params.network.central_value", "True makes a value-only critic, but "
                          "params.network is the actor; put the critic under config.central_value_config.network")
    if isinstance(config, TrainConfig) and config.central_value_config is not None:
        config = dataclasses.replace(config, central_value_config=_resolve_central_value(config, source))
    out = Params(algo=algo, model=model, config=config, network=network, seed=seed,
                 import_modules=modules, torch_threads=threads, update_threads=update_threads,
                 malloc=malloc, source=source)
    if isinstance(config, TrainConfig) and config.multi_agent is not None:
        out = dataclasses.replace(out, policies=_policy_params(out, params, source))
    return out


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

    ma = top.config_as(TrainConfig).multi_agent
    if top.network is not None and isinstance(top.network, (NetworkConfig, ResnetNetworkConfig)) \
            and top.network.rnn is not None:
        raise ConfigError(source, "params.network.rnn", "multi_agent policies are feedforward for now "
                                                        "(recurrent policies: not implemented)")
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
        config = _resolve_training(parse_dataclass(TrainConfig, merged, f"{path}.config", source), source)
        network = top.network if spec.network is None else _parse_network(spec.network, source, f"{path}.network")
        _check_registered(NETWORKS, _network_name(network), f"{path}.network.name", source)
        if isinstance(network, (NetworkConfig, ResnetNetworkConfig)) and network.rnn is not None:
            raise ConfigError(source, f"{path}.network.rnn", "multi_agent policies are feedforward for now")
        model = top.model if spec.model is None else parse_dataclass(
            NamedBlock, compat.translate_model(spec.model, source), f"{path}.model", source)
        _check_registered(MODELS, model.name, f"{path}.model.name", source)
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


def _parse_network(network: Any, source: str, path: str = "params.network") -> Any:
    """Built-in builders get a typed NetworkConfig; user builders may declare ``config_class`` (a class
    attribute, or ``register_network(..., config_class=...)``)."""

    if network is None:
        network = {}
    if not isinstance(network, dict):
        raise ConfigError(source, path, f"expected a mapping, got {network!r}")
    network = compat.translate_network(network, source, path)
    config_class = network_config_class(network.get("name", "actor_critic"))
    if config_class is None:
        return network
    parsed = parse_dataclass(config_class, network, path, source)
    _check_planned(parsed, path, source)
    if isinstance(parsed, (NetworkConfig, ResnetNetworkConfig)):
        chosen = [k for k in ("discrete", "multi_discrete", "continuous")
                  if getattr(parsed.space, k) is not None]
        if len(chosen) > 1:
            raise ConfigError(source, f"{path}.space", f"choose one action head, got {', '.join(chosen)}")
    return parsed


def _network_name(network: Any) -> str:
    return network.name if hasattr(network, "name") else network.get("name", "actor_critic")


def _check_registered(registry: Any, name: str, path: str, source: str) -> None:
    if name not in registry:
        raise ConfigError(source, path, registry.unknown_message(name))


def _check_planned(obj: Any, path: str, source: str) -> None:
    """A key whose feature is not implemented yet may only hold its default value."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        status = f.metadata.get("status", "yes")
        if status.startswith("planned"):
            default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
            if value != default and value not in (None, False, {}):
                raise ConfigError(source, f"{path}.{f.name}",
                                  f"not implemented in rlchain yet ({status}); remove the key or set it "
                                  f"to {default!r}")
        elif dataclasses.is_dataclass(value):
            _check_planned(value, f"{path}.{f.name}", source)


def _check_callbacks(specs: list[str], source: str) -> None:
    """Each ``package.module:Name`` in config.callbacks must import."""
    for i, spec in enumerate(specs):
        module_name, _, attr = spec.partition(":")
        path = f"params.config.callbacks[{i}]"
        if not attr:
            raise ConfigError(source, path, f"'{spec}' must look like 'package.module:Name'")
        try:
            module = importlib.import_module(module_name)
        except ImportError as exc:
            raise ConfigError(source, path, f"cannot import '{module_name}': {exc}") from None
        if not hasattr(module, attr):
            raise ConfigError(source, path, f"module '{module_name}' has no '{attr}'")


def _check_sequences(config: TrainConfig, source: str) -> None:
    """An RNN trains on whole sequences: horizon and minibatch must hold whole seq_length blocks."""
    length = config.seq_length
    if config.horizon_length % length:
        raise ConfigError(source, "params.config.seq_length",
                          f"horizon_length {config.horizon_length} is not divisible by seq_length {length}")
    if config.minibatch_size % length:
        raise ConfigError(source, "params.config.seq_length",
                          f"minibatch_size {config.minibatch_size} is not divisible by seq_length {length}")


def check_batch(config: TrainConfig, source: str, agents: int = 1) -> None:
    """minibatch_size must divide the batch num_actors * horizon_length * ``agents`` (agents per env).

    At load time the env is unknown, so this runs once the env is built (``Runner.train``), with
    its agent count, before a run folder is created.
    """
    batch = config.num_actors * config.horizon_length * agents
    what = "num_actors*horizon_length" + (f"*agents ({agents} per env)" if agents > 1 else "")
    if config.minibatch_size > batch:
        raise ConfigError(source, "params.config.minibatch_size",
                          f"minibatch_size {config.minibatch_size} is larger than the batch {what} = {batch}")
    if batch % config.minibatch_size != 0:
        raise ConfigError(source, "params.config.minibatch_size",
                          f"batch {what} = {batch} is not divisible by minibatch_size {config.minibatch_size}")


def _resolve_central_value(config: TrainConfig, source: str) -> CentralValueConfig:
    """The asymmetric critic: value-only network, a minibatch that divides the batch. Returns the block
    with its network parsed and its minibatch_size resolved (default: the actor's)."""

    cv, path = config.central_value_config, "params.config.central_value_config"
    cv = dataclasses.replace(cv, network=_parse_network(cv.network, source, f"{path}.network"))
    _check_registered(NETWORKS, _network_name(cv.network), f"{path}.network.name", source)
    typed = isinstance(cv.network, NetworkConfig)  # actor_critic; a user network's block is its own
    heads = [k for k in ("discrete", "multi_discrete", "continuous")
             if typed and getattr(cv.network.space, k) is not None]
    if heads:
        raise ConfigError(source, f"{path}.network.space", f"the central value network is a critic (value "
                          f"only); remove the '{heads[0]}' action head")
    if cv.minibatch_size_per_env is not None:
        cv = dataclasses.replace(cv, minibatch_size=config.num_actors * cv.minibatch_size_per_env)
    cv = dataclasses.replace(cv, minibatch_size=cv.minibatch_size or config.minibatch_size)
    batch = config.num_actors * config.horizon_length
    if batch % cv.minibatch_size:
        raise ConfigError(source, f"{path}.minibatch_size", f"batch num_actors*horizon_length = {batch} is not "
                          f"divisible by {cv.minibatch_size}")
    if typed and cv.network.rnn is not None:
        if cv.minibatch_size % config.seq_length or config.horizon_length % config.seq_length:
            raise ConfigError(source, f"{path}.minibatch_size", f"a recurrent critic trains on sequences: "
                              f"minibatch_size {cv.minibatch_size} and horizon_length {config.horizon_length} "
                              f"must divide by seq_length {config.seq_length}")
    return cv


def _resolve_training(config: ActorCriticConfig, source: str) -> ActorCriticConfig:
    """Cross-key checks that no single field can make; returns the config with the derived values
    filled in (minibatch_size from minibatch_size_per_env, lr_schedule constant -> None)."""
    if config.minibatch_size_per_env is not None:
        if config.minibatch_size is not None:
            raise ConfigError(source, "params.config.minibatch_size_per_env",
                              "give minibatch_size or minibatch_size_per_env, not both")
        config = dataclasses.replace(config, minibatch_size=config.num_actors * config.minibatch_size_per_env)
    if config.minibatch_size is None:
        raise ConfigError(source, "params.config.minibatch_size",
                          "required key is missing (or give minibatch_size_per_env)")
    # minibatch_size must divide num_actors * horizon_length * agents per env; the agent count is known
    # once the env is built, so the check runs then (Runner.train, before any run folder exists)
    if not config.env_name:
        raise ConfigError(source, "params.config.env_name", "required key is missing")
    if config.lr_schedule == "constant":
        config = dataclasses.replace(config, lr_schedule=None)
    _check_schedules(config, source)
    return config


def _check_schedules(config: ActorCriticConfig, source: str) -> None:
    """polynom_decay needs a horizon to decay over; keys that only act with another schedule warn."""
    if config.lr_schedule == "polynom_decay" and config.max_epochs <= 0 and config.max_frames <= 0:
        raise ConfigError(source, "params.config.lr_schedule", "polynom_decay decays over the run: set "
                          "max_epochs or max_frames")
    if config.schedule_entropy and config.lr_schedule != "linear":
        compat.warn_once(source, "params.config.schedule_entropy", f"True has no effect with lr_schedule "
                         f"{config.lr_schedule or 'None'}: as in rl_games the entropy schedule runs with "
                         f"lr_schedule linear only; entropy_coef stays {config.entropy_coef}")
    if config.decay_power != 1.0 and config.lr_schedule != "polynom_decay":
        compat.warn_once(source, "params.config.decay_power", f"no effect with lr_schedule "
                         f"{config.lr_schedule or 'None'}; it is the exponent of polynom_decay")
