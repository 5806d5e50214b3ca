"""The search file that both tuning backends read (Optuna: optuna_search.py; Ray Tune: ray_search.py) and
what they share: the space checked against the base config, override strings, the best config written.

A search file (YAML)::

    base: ppo_cartpole.yaml          # the config to tune (relative to this file)
    metric: mean_reward              # or best_reward (from the TrainResult)
    direction: maximize              # or minimize
    trials: 20
    max_epochs_per_trial: 50         # only for the trials, not written to the best config
    overrides: [params.config.lr_schedule=None]   # for the trials and the best config
    seed: 0                          # seeds the sampler (trials use the base config's seed)
    pruner: {n_startup_trials: 2, n_warmup_steps: 5}   # MedianPruner; or: none
    params:
      params.config.learning_rate: {type: loguniform, low: 1.0e-4, high: 1.0e-2}
      params.config.mini_epochs: {type: int, low: 1, high: 8}
      params.config.gamma: {type: categorical, choices: [0.98, 0.99, 0.995]}

With ``backend: ray`` the same file runs on Ray Tune (FIFO, ASHA or population-based training,
trials in parallel, on one machine or a cluster): see :mod:`rlchain.tuning` and docs/tuning.md.

Each trial trains in-process with ``Runner().load(base, overrides).train()``; the epoch's mean
reward is reported to Optuna and bad trials stop early (MedianPruner). The best trial's values
are applied to the base config and written as a runnable YAML (default ``<base name>_best.yaml`` in the
search's run folder), with a CSV table of all trials next to it.

    python runner.py --tune search.yaml            # or: python -m rlchain.tuning.search search.yaml
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
import time
from dataclasses import dataclass, field
from typing import Any

import yaml

from rlchain.config.errors import ConfigError
from rlchain.config.fields import option, parse_dataclass
from rlchain.config.load import apply_overrides, load_raw
from rlchain.errors import optional_import
from rlchain.log import train_hint
from rlchain.runner import Runner
from rlchain.tuning.spec import RAY_KEYS, RaySpec, backend_of, load_ray_spec

INSTALL_HINT = "optuna is not installed: pip install rlchain[tune]"
METRICS = ("mean_reward", "best_reward")
DIRECTIONS = ("maximize", "minimize")
TYPES = {"loguniform": ("low", "high"), "uniform": ("low", "high"), "float": ("low", "high"),
         "int": ("low", "high"), "categorical": ("choices",)}
KEYS = {"base", "metric", "direction", "trials", "max_epochs_per_trial", "overrides", "seed", "pruner",
        "params", "timeout", "verbose"} | RAY_KEYS


def import_optuna() -> Any:
    return optional_import("optuna", INSTALL_HINT)


@dataclass
class SearchSpec:
    """A validated search file."""

    source: str
    base: str
    metric: str = "mean_reward"
    direction: str = "maximize"
    trials: int = 20
    max_epochs_per_trial: int | None = None
    overrides: list[str] = field(default_factory=list)
    seed: int | None = None
    pruner: dict | None = field(default_factory=dict)
    params: dict[str, dict] = field(default_factory=dict)
    timeout: float | None = None
    verbose: bool = False
    backend: str = "optuna"
    ray: RaySpec | None = None  # the Ray Tune keys (backend: ray)

    def trial_overrides(self, study_dir: str, values: list[str] | tuple[str, ...] = ()) -> list[str]:
        """A trial's overrides: the file's, then ``values`` (the trial's own), its runs in ``study_dir``, the
        ``max_epochs_per_trial`` cap, and quiet unless ``verbose``."""
        out = [*self.overrides, *values, f"params.config.train_dir={study_dir}"]
        if self.max_epochs_per_trial is not None:
            out.append(f"params.config.max_epochs={self.max_epochs_per_trial}")
        return out if self.verbose else [*out, "params.config.print_stats=false"]


def _at_least_one(x: int) -> str | None:
    return None if x >= 1 else "expected an integer >= 1"


def _overrides(items: list[str]) -> str | None:
    return None if all("=" in item for item in items) else "expected a list of 'key.path=value' strings"


@dataclass(frozen=True)
class SearchKeys:
    """The scalar keys of a search file, parsed like a config block (rlchain.config.fields)."""

    metric: str = option("mean_reward", "what a trial is ranked by", choices=METRICS)
    direction: str = option("maximize", "maximize or minimize the metric", choices=DIRECTIONS)
    trials: int = option(20, "trials to run", check=_at_least_one)
    max_epochs_per_trial: int | None = option(None, "params.config.max_epochs of every trial", check=_at_least_one)
    overrides: list[str] = option([], "key.path=value overrides of the base config for every trial",
                                  check=_overrides)
    seed: int | None = option(None, "seed of the sampler (and of the trials)")
    timeout: float | None = option(None, "seconds for the whole search",
                                   check=lambda x: None if x > 0 else "expected seconds > 0")
    verbose: bool = option(False, "print every trial's training progress")


SEARCH_KEYS = {f.name for f in dataclasses.fields(SearchKeys)}


def load_search(path: str) -> SearchSpec:
    """Read and validate a search file; every problem is a one-line ConfigError naming file and key."""
    raw = load_raw(path)  # ConfigError for a missing/unparsable file or a non-mapping

    def err(key: str, message: str) -> ConfigError:
        return ConfigError(path, key, message)

    for key in raw:
        if key not in KEYS:
            raise err(key, f"unknown key (valid: {', '.join(sorted(KEYS))})")
    if "base" not in raw or not isinstance(raw["base"], str) or not raw["base"]:
        raise err("base", "required: the path of the config to tune")
    base = raw["base"]
    if not os.path.isabs(base) and not os.path.isfile(base):
        base = os.path.join(os.path.dirname(os.path.abspath(path)), base)
    if not os.path.isfile(base):
        raise err("base", f"config file '{raw['base']}' not found")
    spec = SearchSpec(source=path, base=os.path.normpath(base))
    spec.backend = backend_of(raw, path)
    if spec.backend == "ray":
        spec.ray = load_ray_spec(raw, path, _check_dist)
    top = parse_dataclass(SearchKeys, {k: v for k, v in raw.items() if k in SEARCH_KEYS and v is not None}, "",
                          path)
    for f in dataclasses.fields(SearchKeys):
        setattr(spec, f.name, getattr(top, f.name))
    spec.pruner = _pruner_spec(raw.get("pruner", {}), err)
    params = raw.get("params")
    if params is None and spec.ray is not None and spec.ray.pbt is not None:
        params = {}  # pbt: the first values are drawn from the mutations
    if not isinstance(params, dict) or (not params and spec.ray is None):
        raise err("params", "required: a mapping of key.path -> {type: ..., ...}")
    for key, dist in params.items():
        spec.params[_full_key(str(key))] = _check_dist(dist, err, f"params.{key}")
    return spec


def _full_key(key: str) -> str:
    return key if key.startswith("params.") else f"params.{key}"


def _pruner_spec(value: Any, err: Any) -> dict | None:
    if value is None or value in ("none", "None", False):
        return None
    if not isinstance(value, dict):
        raise err("pruner", "expected a mapping {n_startup_trials, n_warmup_steps} or none")
    for key, item in value.items():
        if key not in ("n_startup_trials", "n_warmup_steps", "interval_steps"):
            raise err(f"pruner.{key}", "unknown key (valid: n_startup_trials, n_warmup_steps, interval_steps)")
        if not isinstance(item, int) or isinstance(item, bool) or item < 0:
            raise err(f"pruner.{key}", f"expected an integer >= 0, got {item!r}")
    return dict(value)


def _number(value: Any) -> float | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return float(value)
    try:
        return float(value)  # YAML reads 1e-4 (no dot) as a string
    except (TypeError, ValueError):
        return None


def _check_dist(dist: Any, err: Any, key: str) -> dict:
    if not isinstance(dist, dict) or "type" not in dist:
        raise err(key, f"expected a mapping with 'type' ({', '.join(TYPES)})")
    kind = dist["type"]
    if kind not in TYPES:
        raise err(f"{key}.type", f"'{kind}' is not one of {', '.join(TYPES)}")
    allowed = set(TYPES[kind]) | {"type", "log", "step"}
    for name in dist:
        if name not in allowed:
            raise err(f"{key}.{name}", f"unknown key for type {kind} (valid: {', '.join(sorted(allowed))})")
    for name in TYPES[kind]:
        if name not in dist:
            raise err(f"{key}.{name}", f"required for type {kind}")
    if kind == "categorical":
        if not isinstance(dist["choices"], list) or not dist["choices"]:
            raise err(f"{key}.choices", "expected a non-empty list")
        return {"type": kind, "choices": list(dist["choices"])}
    out: dict[str, Any] = {"type": kind}
    for name in ("low", "high"):
        value = _number(dist[name])
        if value is None or not math.isfinite(value):
            raise err(f"{key}.{name}", f"expected a number, got {dist[name]!r}")
        if kind == "int" and value != int(value):
            raise err(f"{key}.{name}", f"expected an integer, got {dist[name]!r}")
        out[name] = int(value) if kind == "int" else value
    if out["low"] >= out["high"]:
        raise err(key, f"low ({out['low']}) must be below high ({out['high']})")
    log = kind == "loguniform" or bool(dist.get("log", False))
    if log and out["low"] <= 0:
        raise err(f"{key}.low", "must be > 0 for a log scale")
    out["log"] = log
    if "step" in dist:
        step = _number(dist["step"])
        if step is None or step <= 0:
            raise err(f"{key}.step", f"expected a number > 0, got {dist['step']!r}")
        out["step"] = int(step) if kind == "int" else step
    return out


def override_strings(values: dict[str, Any]) -> list[str]:
    return [f"{key}={yaml.safe_dump(value, default_flow_style=True).strip().removesuffix('...').strip()}"
            for key, value in values.items()]


def check_space(spec: SearchSpec) -> None:
    """Fail before any training when a searched key or override does not fit the base config."""
    for key, dist in spec.params.items():
        for value in (dist["choices"] if dist["type"] == "categorical" else (dist["low"], dist["high"])):
            try:
                Runner().load(spec.base, spec.overrides + override_strings({key: value}))
            except ConfigError as exc:
                raise ConfigError(spec.source, f"params.{key}", f"value {value!r} is rejected: {exc}") from None


def write_best_config(spec: SearchSpec, values: dict[str, Any], output: str, value: float,
                      number: int) -> str:
    """The base config with the search's overrides and the best values applied, as YAML."""
    raw = apply_overrides(load_raw(spec.base), spec.overrides + override_strings(values), spec.base)
    folder = os.path.dirname(os.path.abspath(output))
    os.makedirs(folder, exist_ok=True)
    with open(output, "w", encoding="utf-8") as fh:
        fh.write(f"# rlchain tune: best of {spec.source} (trial {number}, {spec.metric} {value:.2f})\n")
        fh.write(f"# base: {spec.base}\n")
        for key, item in values.items():
            fh.write(f"#   {key} = {fmt(item)}\n")
        yaml.safe_dump(raw, fh, sort_keys=False)
    return output


def fmt(value: Any) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def study_folder(spec: SearchSpec, train_dir: str, output: str | None) -> tuple[str, str]:
    """The search's run folder (``tune_<base>_<time>`` under ``train_dir``, where the trials' runs go) and the
    best config's path (``output``, by default ``<base>_best.yaml`` in that folder, not in the cwd)."""
    stem = os.path.splitext(os.path.basename(spec.base))[0]
    study_dir = os.path.abspath(os.path.join(train_dir, f"tune_{stem}_{time.strftime('%d-%H-%M-%S')}"))
    if os.path.exists(study_dir):
        study_dir = f"{study_dir}_{os.getpid()}"
    return study_dir, output or os.path.join(study_dir, f"{stem}_best.yaml")


def report(spec: SearchSpec, keys: list[str], rows: list[list[Any]], output: str, best: tuple[Any, float],
           values: dict[str, Any], note: str = "", schedule_path: str | None = None) -> tuple[str, str]:
    """The search's outputs: the best config (:func:`write_best_config`: the ``best`` trial and value, with its
    ``values``) at ``output``; every trial's row (trial, state, metric, epochs, the values of ``keys``) as a CSV
    beside it (``<output stem>_trials.csv``) and as a fixed-width table on stdout; then the best trial and how
    to train its config. Returns (best config, CSV)."""
    path = write_best_config(spec, values, output, float(best[1]), best[0])
    header = ["trial", "state", spec.metric, "epochs"]
    rows = [[fmt(c) for c in row] for row in rows]
    table_path = os.path.splitext(output)[0] + "_trials.csv"
    with open(table_path, "w", encoding="utf-8", newline="") as fh:
        csv.writer(fh).writerows([header + keys] + rows)
    text = [header + [k.removeprefix("params.config.") for k in keys]] + rows
    widths = [max(len(row[i]) for row in text) for i in range(len(text[0]))]
    print("\n".join("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip() for row in text))
    print(f"best trial {best[0]}: {spec.metric} {best[1]:.2f} with "
          + ", ".join(f"{k}={fmt(v)}" for k, v in values.items()) + note, flush=True)
    print(f"best config: {path} (train with: {train_hint(path)}); trials: {table_path}"
          + (f"; winner's schedule: {schedule_path}" if schedule_path else ""), flush=True)
    return path, table_path
