"""The Ray Tune keys of a search file (``backend: ray``), validated without importing Ray.

The rest of the file (base, metric, direction, trials, max_epochs_per_trial, overrides, seed,
params) is read by :func:`rlchain.tuning.common.load_search`, as for the in-process Optuna search::

    backend: ray                  # optuna (default, in-process) or ray
    scheduler: pbt                # fifo | asha | pbt
    searcher: random              # random | grid | optuna (TPE); default optuna, random under pbt
    concurrent: 2                 # trials at once
    resources: {cpus: 1, gpus: 0} # per trial
    ray: {address: local}         # local (start Ray here) | auto | ray://head:10001; num_cpus, storage_path
    max_failures: 2               # a crashed trial restarts from its last checkpoint this often
    checkpoint_epochs: 10         # a Tune checkpoint every N epochs (default: pbt interval, else 10)
    asha: {grace_epochs: 10, reduction_factor: 3}
    pbt: {interval_epochs: 20, quantile: 0.25, resample_probability: 0.25,
          mutations: {params.config.learning_rate: {type: loguniform, low: 1e-5, high: 1e-2}}}
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.fields import option, parse_dataclass

RAY_KEYS = frozenset({"backend", "scheduler", "searcher", "concurrent", "resources", "ray", "pbt", "asha",
                      "max_failures", "checkpoint_epochs"})
BACKENDS = ("optuna", "ray")
SCHEDULERS = ("fifo", "asha", "pbt")
SEARCHERS = ("random", "grid", "optuna")
RAY_INSTALL_HINT = "Ray Tune is not installed: pip install rlchain[ray]"


def _at_least(minimum: float, maximum: float = math.inf, integer: bool = False) -> Any:
    """A field check with the search file's message: 'expected an integer >= 1' / 'a number >= x and <= y'."""
    what = "an integer" if integer else "a number"
    bound = f" and <= {maximum:g}" if math.isfinite(maximum) else ""
    return lambda x: None if minimum <= x <= maximum else f"expected {what} >= {minimum:g}{bound}"


def _factors(x: list[float]) -> str | None:
    return None if len(x) == 2 and all(f > 0 for f in x) else "expected two numbers > 0 like [1.2, 0.8]"


@dataclass(frozen=True)
class PbtSpec:
    """Population-based training: every ``interval_epochs`` the bottom ``quantile`` of the trials
    load a top trial's checkpoint and perturb its ``mutations`` (live, through set_params)."""

    interval_epochs: int = option(20, "epochs between exploit/explore steps", check=_at_least(1, integer=True))
    quantile: float = option(0.25, "the bottom (and top) fraction of the trials", check=_at_least(1e-9, 0.5))
    resample_probability: float = option(0.25, "chance a mutated value is drawn again instead of perturbed",
                                         check=_at_least(0.0, 1.0))
    perturbation_factors: list[float] = option([1.2, 0.8], "factors a continuous value is perturbed by",
                                               check=_factors)
    mutations: dict = option({}, "key.path -> distribution, perturbed live (required)")


@dataclass(frozen=True)
class AshaSpec:
    """Asynchronous successive halving: trials are compared at ``grace_epochs * reduction_factor**k``."""

    grace_epochs: int = option(10, "epochs before a trial can be stopped", check=_at_least(1, integer=True))
    reduction_factor: float = option(3.0, "halving rate", check=_at_least(1.0 + 1e-9))
    brackets: int = option(1, "brackets", check=_at_least(1, integer=True))


@dataclass
class RaySpec:
    """The validated Ray keys of a search file."""

    scheduler: str = "fifo"
    searcher: str = "optuna"
    concurrent: int = 1
    cpus: float = 1.0
    gpus: float = 0.0
    address: str | None = None  # None: start a local Ray instance
    num_cpus: int | None = None  # local Ray only
    storage_path: str | None = None
    max_failures: int = 2
    checkpoint_epochs: int = 10
    pbt: PbtSpec | None = None
    asha: AshaSpec | None = None


def backend_of(raw: dict, path: str) -> str:
    """The file's backend (optuna unless it says ray); ray-only keys under optuna are errors."""
    backend = raw.get("backend", "optuna")
    if backend not in BACKENDS:
        raise ConfigError(path, "backend", f"'{backend}' is not one of {', '.join(BACKENDS)}")
    if backend == "optuna":
        extra = sorted(k for k in raw if k in RAY_KEYS and k != "backend")
        if extra:
            raise ConfigError(path, extra[0], "only with backend: ray (this file runs the in-process Optuna "
                                              "search)")
    return backend


def load_ray_spec(raw: dict, path: str, check_dist: Any) -> RaySpec:
    """Validate the Ray keys of ``raw`` (a search file read by rlchain.tuning.common.load_search);
    ``check_dist`` validates one distribution (the Optuna path's own checker)."""

    def err(key: str, message: str) -> ConfigError:
        return ConfigError(path, key, message)

    spec = RaySpec()
    spec.scheduler = raw.get("scheduler", "fifo")
    if spec.scheduler not in SCHEDULERS:
        raise err("scheduler", f"unknown scheduler '{spec.scheduler}' (valid: {', '.join(SCHEDULERS)})")
    spec.searcher = raw.get("searcher", "random" if spec.scheduler == "pbt" else "optuna")
    if spec.searcher not in SEARCHERS:
        raise err("searcher", f"unknown searcher '{spec.searcher}' (valid: {', '.join(SEARCHERS)})")
    if spec.scheduler == "pbt" and spec.searcher != "random":
        raise err("searcher", f"pbt samples its own population: searcher must be random, not {spec.searcher}")
    spec.concurrent = _int(raw.get("concurrent", 1), err, "concurrent", 1)
    spec.max_failures = _int(raw.get("max_failures", spec.max_failures), err, "max_failures", 0)
    resources = _mapping(raw.get("resources", {}), err, "resources", ("cpus", "gpus"))
    spec.cpus = _float(resources.get("cpus", 1), err, "resources.cpus", minimum=1e-9)
    spec.gpus = _float(resources.get("gpus", 0), err, "resources.gpus", minimum=0.0)
    ray = _mapping(raw.get("ray", {}), err, "ray", ("address", "num_cpus", "storage_path"))
    address = ray.get("address", "local")
    if not isinstance(address, str) or not address:
        raise err("ray.address", f"expected local, auto or host:port / ray://host:port, got {address!r}")
    spec.address = None if address == "local" else address
    if ray.get("num_cpus") is not None:
        if spec.address is not None:
            raise err("ray.num_cpus", "only for a local Ray (address: local); a cluster has its own CPUs")
        spec.num_cpus = _int(ray["num_cpus"], err, "ray.num_cpus", 1)
    if ray.get("storage_path") is not None:
        if not isinstance(ray["storage_path"], str):
            raise err("ray.storage_path", "expected a folder or a URI (s3://..., gs://...)")
        storage = ray["storage_path"]
        if "://" not in storage and not os.path.isabs(storage):
            storage = os.path.join(os.path.dirname(os.path.abspath(path)), storage)
        spec.storage_path = storage
    if "asha" in raw and spec.scheduler != "asha":
        raise err("asha", f"only with scheduler: asha (the file says {spec.scheduler})")
    if "pbt" in raw and spec.scheduler != "pbt":
        raise err("pbt", f"only with scheduler: pbt (the file says {spec.scheduler})")
    if spec.scheduler == "asha":
        spec.asha = parse_dataclass(AshaSpec, _mapping(raw.get("asha", {}), err, "asha", _names(AshaSpec)), "asha",
                                    path)
    if spec.scheduler == "pbt":
        spec.pbt = _pbt(raw.get("pbt"), err, check_dist, path)
    default_every = spec.pbt.interval_epochs if spec.pbt else 10
    spec.checkpoint_epochs = _int(raw.get("checkpoint_epochs", default_every), err, "checkpoint_epochs", 1)
    return spec


def _pbt(value: Any, err: Any, check_dist: Any, path: str) -> PbtSpec:
    pbt = dict(_mapping(value, err, "pbt", _names(PbtSpec)))
    mutations = pbt.pop("mutations", None)
    if not isinstance(mutations, dict) or not mutations:
        raise err("pbt.mutations", "required: a mapping of key.path -> {type: ..., ...} that PBT perturbs live")
    spec = parse_dataclass(PbtSpec, pbt, "pbt", path)
    checked = {}
    for key, dist in mutations.items():
        full = str(key) if str(key).startswith("params.") else f"params.{key}"
        checked[full] = check_dist(dist, err, f"pbt.mutations.{key}")
    return dataclasses.replace(spec, perturbation_factors=tuple(spec.perturbation_factors), mutations=checked)


def _names(cls: type) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(cls))


def check_live_keys(keys: list[str], tunable: tuple[str, ...], algo: str, path: str, where: str) -> None:
    """Every key must be ``params.config.<name>`` with ``name`` in the algorithm's ``tunable``: what
    the run's live set_params can change while the trial runs (PBT's explore step, an exploit)."""
    for key in keys:
        name = key.removeprefix("params.config.")
        if not key.startswith("params.config.") or name not in tunable:
            raise ConfigError(path, f"{where}.{key}", f"cannot change live for {algo}: PBT changes only the "
                              f"algorithm's tunable params.config keys ({', '.join(tunable)})")


def check_capacity(spec: RaySpec, cpus: float, gpus: float, path: str, where: str) -> None:
    """More concurrent trials than the CPUs (or GPUs) allow is a one-line error, before any trial."""
    need = spec.concurrent * spec.cpus
    if need > cpus + 1e-9:
        raise ConfigError(path, "concurrent", f"{spec.concurrent} trials x {spec.cpus:g} CPUs need {need:g} CPUs "
                          f"but {where} has {cpus:g}; lower concurrent or resources.cpus")
    if spec.gpus > 0 and spec.concurrent * spec.gpus > gpus + 1e-9:
        raise ConfigError(path, "concurrent", f"{spec.concurrent} trials x {spec.gpus:g} GPUs need "
                          f"{spec.concurrent * spec.gpus:g} GPUs but {where} has {gpus:g}")


def _mapping(value: Any, err: Any, key: str, allowed: tuple[str, ...]) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise err(key, f"expected a mapping with keys {', '.join(allowed)}")
    for name in value:
        if name not in allowed:
            raise err(f"{key}.{name}", f"unknown key (valid: {', '.join(allowed)})")
    return value


def _int(value: Any, err: Any, key: str, minimum: int) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or value < minimum:
        raise err(key, f"expected an integer >= {minimum}, got {value!r}")
    return value


def _float(value: Any, err: Any, key: str, minimum: float, maximum: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not minimum <= value <= maximum:
        bound = f" and <= {maximum:g}" if math.isfinite(maximum) else ""
        raise err(key, f"expected a number >= {minimum:g}{bound}, got {value!r}")
    return float(value)
