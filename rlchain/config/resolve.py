"""After parsing: :func:`resolve` makes one process's run context, and checkpoints store the config as data.

Parsing gives a frozen :class:`~rlchain.config.params.Params`, the same on every process of a run.
What differs per process (the seed, and under torchrun the rank's device, its ``env_config`` seed
and whether it prints) goes into a :class:`ProcessContext` made once by :func:`resolve`; nothing
assigns to the parsed config afterwards. Checkpoints store the resolved config as plain data
(:func:`config_state`) and :func:`params_from_state` turns it back into Params with the same field
checks as a config file (:func:`rlchain.config.fields.parse_dataclass`).
"""

from __future__ import annotations

import dataclasses
import secrets
from dataclasses import dataclass
from typing import Any

from rlchain.config.algo_keys import config_class_of
from rlchain.config.errors import ConfigError
from rlchain.config.fields import parse_dataclass, parse_value
from rlchain.config.load import check_malloc
from rlchain.config.network_block import parse_network
from rlchain.config.params import NamedBlock, Params
from rlchain.registry import ALGOS

CONFIG_FORMAT = "rlchain-config-2"
"""``config_format`` of a checkpoint whose ``config`` is the resolved config (:func:`config_state`);
a checkpoint without it (a pre-release rlchain's, holding the input file's dict) is refused."""

RANK_SEED_STRIDE = 100_003  # rank r seeds its envs and RNGs with seed + r * this (a prime > any num_actors)


@dataclass(frozen=True)
class ProcessContext:
    """What one process runs with: the config with its per-process values, and those values by name."""

    params: Params  # the parsed config, with device / print_stats / env_config of this process
    seed: int  # this process's seed (torchrun: the run's seed + rank * RANK_SEED_STRIDE)
    rank: int = 0
    world_size: int = 1


def resolve(params: Params, seed: int | None, group: Any = None) -> ProcessContext:
    """The run context of this process: ``group`` is the torchrun :class:`~rlchain.parallel.distributed.
    Distributed` (None for a single process). A missing seed is drawn here. Under torchrun a CUDA run moves
    to the rank's ``cuda:LOCAL_RANK`` (and a tensor env's ``env_config.device`` with it), ``env_config.seed``
    is offset per rank and ranks other than 0 do not print progress."""
    if group is None:
        return ProcessContext(params, secrets.randbelow(2**31) if seed is None else int(seed))
    changes: dict[str, Any] = {}
    env_config = dict(params.config.env_config)
    device = getattr(group, "device", None)
    if device is not None:  # nccl: this rank's GPU
        changes["device"] = device
        if str(env_config.get("device", "")).startswith("cuda"):
            env_config["device"] = device
    if env_config.get("seed") is not None:
        env_config["seed"] = int(env_config["seed"]) + group.rank * RANK_SEED_STRIDE
    if env_config != params.config.env_config:
        changes["env_config"] = env_config
    if group.rank != 0:
        changes["print_stats"] = False
    return ProcessContext(with_config(params, **changes), group.rank_seed, group.rank, group.world_size)


def with_config(params: Params, **changes: Any) -> Params:
    """``params`` with ``changes`` to its config (and to each multi_agent policy's): a new value, the
    argument is left as it is."""
    if not changes:
        return params
    policies = None if params.policies is None else {name: with_config(p, **changes)
                                                     for name, p in params.policies.items()}
    return dataclasses.replace(params, config=dataclasses.replace(params.config, **changes), policies=policies)


def config_state(params: Params, run: dict[str, Any] | None = None) -> dict[str, Any]:
    """The resolved config as plain data for a checkpoint: ``{'params': ..., 'run': ...}``."""
    return {"params": _params_dict(params), "run": dict(run or {})}


def _params_dict(params: Params) -> dict[str, Any]:
    out = {f.name: _plain(getattr(params, f.name)) for f in dataclasses.fields(params)
           if f.name not in ("source", "policies")}
    if params.policies is not None:
        out["policies"] = {name: _params_dict(p) for name, p in params.policies.items()}
    return out


def _plain(value: Any) -> Any:
    """Dataclasses as dicts; a None that is the field's default is left out (``discrete:`` with no value
    selects the head, so an absent head must stay absent)."""
    if dataclasses.is_dataclass(value):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)
                if not (getattr(value, f.name) is None and f.default is None)}
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def params_from_state(data: Any, source: str) -> Params:
    """Params from :func:`config_state`'s ``params`` (plain data), checked field by field like a config file.
    The cross-key checks and derivations ran when the config was first parsed; their results are stored."""

    if not isinstance(data, dict) or not {"algo", "model", "config"} <= set(data):
        raise ConfigError(source, "config", "the checkpoint's config has no algo, model and config")
    algo = parse_dataclass(NamedBlock, data["algo"], "params.algo", source)
    model = parse_dataclass(NamedBlock, data["model"], "params.model", source)
    if algo.name not in ALGOS:
        raise ConfigError(source, "params.algo.name", ALGOS.unknown_message(algo.name))
    config = parse_dataclass(config_class_of(algo.name), data["config"], "params.config", source)
    cv = getattr(config, "central_value_config", None)  # PPO's asymmetric critic
    if cv is not None:
        network = parse_network(cv.network, source, "params.config.central_value_config.network")
        config = dataclasses.replace(config, central_value_config=dataclasses.replace(cv, network=network))
    policies = data.get("policies")
    return Params(
        algo=algo, model=model, config=config, network=parse_network(data.get("network"), source),
        seed=parse_value(int | None, data.get("seed"), "params.seed", source),
        import_modules=parse_value(list[str] | None, data.get("import_modules"), "params.import_modules", source),
        torch_threads=parse_value(int | None, data.get("torch_threads"), "params.torch_threads", source),
        update_threads=parse_value(int | None, data.get("update_threads"), "params.update_threads", source),
        malloc=parse_value(str, data.get("malloc", "keep"), "params.malloc", source, {"check": check_malloc}),
        source=source,
        policies=None if policies is None else {name: params_from_state(p, source) for name, p in policies.items()})
