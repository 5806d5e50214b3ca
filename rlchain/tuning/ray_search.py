"""``--tune`` with ``backend: ray``: the search file's trials on Ray Tune (FIFO, ASHA, PBT).

The driver (this process) validates the file, connects to Ray (a local instance, or a cluster with
``ray: {address: auto}``), and runs a Tuner whose trials are :class:`rlchain.tuning.trainable.
RlchainTrainable` actors. It writes what the Optuna path writes (the best config as a runnable YAML,
a CSV of the trials) and, for PBT, the winner's schedule as a replayable config
(``params.config.hyperparam_schedule``).
"""

from __future__ import annotations

import contextlib
import functools
import json
import math
import os
import random
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import yaml

from rlchain.config.errors import ConfigError
from rlchain.config.load import apply_overrides, load_raw
from rlchain.errors import optional_import
from rlchain.log import train_hint
from rlchain.registry import ALGOS
from rlchain.runner import Runner
from rlchain.tuning.common import check_space, fmt, import_optuna, override_strings, report, study_folder
from rlchain.tuning.spec import RAY_INSTALL_HINT, RaySpec, check_capacity, check_live_keys


def import_ray_tune() -> Any:
    """``ray.tune``, or a one-line ImportError naming the extra to install."""
    return optional_import("ray.tune", RAY_INSTALL_HINT)


@dataclass
class SearchOutcome:
    """What a Ray search produced."""

    best_value: float
    best_trial: str
    best_values: dict[str, Any]
    config_path: str
    schedule_path: str | None
    table_path: str
    exploits: list[dict] = field(default_factory=list)  # every PBT exploit of every trial
    results: Any = None  # ray.tune.ResultGrid


def run_ray_search(spec: Any, output: str | None = None, train_dir: str | None = None) -> tuple[float, str]:
    """Run the search on Ray Tune; returns (best value, path of the written best config)."""
    outcome = fit(spec, output, train_dir)
    return outcome.best_value, outcome.config_path


def validate(spec: Any) -> tuple[Any, tuple[str, ...]]:
    """Every check that needs no Ray: the searched and mutated keys against the base config and the
    algorithm's live ``tunable``, and (for a local Ray) the CPUs. Returns (base Runner, tunable)."""

    rs: RaySpec = spec.ray
    base = Runner().load(spec.base, spec.overrides)
    tunable = _tunable(base.params.algo.name)
    _check_keys(spec, tunable, base.params.algo.name)
    if rs.searcher == "grid":
        for key, dist in spec.params.items():
            grid_values(dist, key, spec.source)
    if rs.address is None:  # a local Ray: the CPUs are known before starting it
        check_capacity(rs, float(rs.num_cpus or os.cpu_count() or 1), math.inf, spec.source, "this machine")
    return base, tunable


def fit(spec: Any, output: str | None = None, train_dir: str | None = None) -> SearchOutcome:
    """Validate, connect to Ray, run the Tuner and write the best config (and schedule)."""
    base, tunable = validate(spec)
    tune = import_ray_tune()
    import ray

    from rlchain.tuning.trainable import RlchainTrainable, TrialSetup  # optional: ray

    rs: RaySpec = spec.ray
    study_dir, output = study_folder(spec, train_dir or base.params.config.train_dir, output)
    if spec.seed is not None:  # PBT's perturbations and the random searcher draw from these
        random.seed(spec.seed)
        np.random.seed(spec.seed)
    handlers = _signal_handlers()  # Ray and Tune install their own; the caller gets its back
    started = _connect(ray, rs)
    try:
        resources = ray.cluster_resources()
        check_capacity(rs, float(resources.get("CPU", 0)), float(resources.get("GPU", 0)), spec.source,
                       "the Ray cluster" if rs.address else "this machine")
        keys = list(spec.params) + [k for k in (rs.pbt.mutations if rs.pbt else {}) if k not in spec.params]
        cfg = base.params.config
        overrides = spec.trial_overrides(study_dir)
        setup = TrialSetup(base=load_raw(spec.base), overrides=overrides, keys=keys,
                           live={k: k.removeprefix("params.config.") for k in keys
                                 if k.removeprefix("params.config.") in tunable and k.startswith("params.config.")},
                           seed=int(base.params.seed if base.params.seed is not None else (spec.seed or 0)),
                           envpool=cfg.env_name == "envpool" or cfg.vecenv_type == "envpool",
                           worst=-math.inf if spec.direction == "maximize" else math.inf)
        trainable = tune.with_resources(tune.with_parameters(RlchainTrainable, setup=setup),
                                        {"cpu": rs.cpus, "gpu": rs.gpus})
        mode = "max" if spec.direction == "maximize" else "min"
        stop: dict[str, Any] = {}
        if spec.max_epochs_per_trial is not None:
            stop["training_iteration"] = spec.max_epochs_per_trial
        if math.isfinite(cfg.score_to_win) and spec.direction == "maximize":
            stop["mean_reward"] = cfg.score_to_win
        tuner = tune.Tuner(
            trainable,
            param_space=param_space(tune, spec.params, rs.searcher, spec.source),
            tune_config=tune.TuneConfig(
                metric=spec.metric, mode=mode, num_samples=spec.trials, max_concurrent_trials=rs.concurrent,
                scheduler=make_scheduler(tune, rs, spec.metric, mode), search_alg=make_searcher(rs, spec, mode),
                reuse_actors=True, time_budget_s=spec.timeout),
            run_config=tune.RunConfig(
                name=os.path.basename(study_dir), storage_path=rs.storage_path or study_dir, stop=stop or None,
                failure_config=tune.FailureConfig(max_failures=rs.max_failures),
                checkpoint_config=tune.CheckpointConfig(checkpoint_frequency=rs.checkpoint_epochs,
                                                        checkpoint_at_end=True),
                verbose=1 if spec.verbose else 0, callbacks=_loggers()))
        if spec.pruner and rs.scheduler != "asha":
            print("rlchain tune: note: pruner is the in-process Optuna search's early stopping; on Ray Tune "
                  "scheduler: asha stops trials early", flush=True)
        print(f"rlchain tune: {spec.trials} trials of {spec.base} on Ray Tune ({rs.scheduler}, {rs.searcher}, "
              f"{rs.concurrent} at once), {spec.direction} {spec.metric} -> {study_dir}", flush=True)
        with _no_tune_tensorboard():
            results = tuner.fit()
        return _write_outputs(spec, results, output, mode)
    finally:
        if started:
            ray.shutdown()
        _restore_signal_handlers(handlers)


def _loggers() -> list:
    """Tune's CSV and JSON results (the trials' metric history); no Tune TensorBoard: each trial's
    rlchain run writes rlchain's TensorBoard tags itself."""
    from ray.tune.logger import CSVLoggerCallback, JsonLoggerCallback

    return [CSVLoggerCallback(), JsonLoggerCallback()]


@contextlib.contextmanager
def _no_tune_tensorboard() -> Any:
    key = "TUNE_DISABLE_AUTO_CALLBACK_LOGGERS"
    previous = os.environ.get(key)
    os.environ[key] = "1"
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = previous


def _signal_handlers() -> dict[int, Any]:
    import signal

    return {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}


def _restore_signal_handlers(handlers: dict[int, Any]) -> None:
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        for sig, handler in handlers.items():
            if handler is not None:
                signal.signal(sig, handler)


def _tunable(algo: str) -> tuple[str, ...]:

    return tuple(getattr(ALGOS.get(algo), "tunable", ()))


def _check_keys(spec: Any, tunable: tuple[str, ...], algo: str) -> None:
    """Searched and mutated keys must exist in the base config (and take their range); under pbt
    every one must change live (the algorithm's ``tunable``), since exploits copy running trials."""

    rs: RaySpec = spec.ray
    check_space(spec)
    if rs.pbt is None:
        return
    for key, dist in rs.pbt.mutations.items():
        probe = type(spec)(source=spec.source, base=spec.base, overrides=spec.overrides, params={key: dist})
        try:
            check_space(probe)
        except ConfigError as exc:
            raise ConfigError(spec.source, f"pbt.mutations.{key}", exc.message) from None
        check_live_keys([key], tunable, algo, spec.source, "pbt.mutations")
    check_live_keys(list(spec.params), tunable, algo, spec.source, "params")


def _connect(ray: Any, rs: RaySpec) -> bool:
    """Start a local Ray (or join ``ray.address``) unless this process already has one; True when
    this call started it. Trials import the rlchain this driver runs (its folder on PYTHONPATH)."""
    if ray.is_initialized():
        return False
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    path = os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH", "")) if p)
    kwargs: dict[str, Any] = {"runtime_env": {"env_vars": {"PYTHONPATH": path}}, "logging_level": "WARNING",
                              "include_dashboard": False}
    if rs.address is None:
        kwargs["num_cpus"] = rs.num_cpus or os.cpu_count() or 1
    else:
        kwargs["address"] = rs.address
    ray.init(**kwargs)
    return True


def domain(tune: Any, dist: dict) -> Any:
    """A search-file distribution as a Tune search space."""
    kind = dist["type"]
    if kind == "categorical":
        return tune.choice(dist["choices"])
    if kind == "int":
        step = dist.get("step", 1)
        if dist["log"]:
            return tune.lograndint(dist["low"], dist["high"] + 1)
        return tune.qrandint(dist["low"], dist["high"], step)
    if dist.get("step") is not None:
        return tune.quniform(dist["low"], dist["high"], dist["step"])
    return (tune.loguniform if dist["log"] else tune.uniform)(dist["low"], dist["high"])


def grid_values(dist: dict, key: str, source: str) -> list:
    """The values a grid searcher tries: categorical choices, or every int of a range."""
    if dist["type"] == "categorical":
        return list(dist["choices"])
    if dist["type"] == "int" and not dist["log"]:
        return list(range(dist["low"], dist["high"] + 1, dist.get("step", 1)))
    raise ConfigError(source, f"params.{key}", f"searcher grid needs categorical or int values, not "
                      f"{dist['type']}")


def param_space(tune: Any, params: dict[str, dict], searcher: str, source: str = "") -> dict:
    if searcher == "grid":
        return {key: tune.grid_search(grid_values(dist, key, source)) for key, dist in params.items()}
    return {key: domain(tune, dist) for key, dist in params.items()}


def make_searcher(rs: RaySpec, spec: Any, mode: str) -> Any:
    """Optuna's TPE through Tune's OptunaSearch; random and grid are Tune's own variant generator."""
    if rs.searcher != "optuna" or not spec.params:
        return None

    import_optuna()  # the one-line hint when optuna is missing
    from ray.tune.search.optuna import OptunaSearch

    return OptunaSearch(metric=spec.metric, mode=mode, seed=spec.seed)


def make_scheduler(tune: Any, rs: RaySpec, metric: str, mode: str) -> Any:
    """FIFO, ASHA (on epochs) or PBT (every interval_epochs, mutations perturbed live)."""
    from ray.tune.schedulers import ASHAScheduler, FIFOScheduler, PopulationBasedTraining

    if rs.scheduler == "asha":
        return ASHAScheduler(time_attr="training_iteration", grace_period=rs.asha.grace_epochs,
                             reduction_factor=rs.asha.reduction_factor, brackets=rs.asha.brackets,
                             max_t=10**9)
    if rs.scheduler == "pbt":
        return PopulationBasedTraining(
            time_attr="training_iteration", perturbation_interval=rs.pbt.interval_epochs,
            quantile_fraction=rs.pbt.quantile, resample_probability=rs.pbt.resample_probability,
            perturbation_factors=rs.pbt.perturbation_factors, require_attrs=False, log_config=False,
            custom_explore_fn=functools.partial(clip_to_ranges, mutations=rs.pbt.mutations),
            hyperparam_mutations={key: domain(tune, dist) for key, dist in rs.pbt.mutations.items()})
    return FIFOScheduler()


def clip_to_ranges(config: dict, mutations: dict[str, dict]) -> dict:
    """PBT's explore step multiplies values by its perturbation factors: keep each mutated value in its
    distribution's [low, high] (a gamma of 0.99 * 1.2 would be invalid)."""
    for key, dist in mutations.items():
        if key in config and dist["type"] != "categorical":
            value = min(max(config[key], dist["low"]), dist["high"])
            config[key] = int(round(value)) if dist["type"] == "int" else float(value)
    return config


def _write_outputs(spec: Any, results: Any, output: str, mode: str) -> SearchOutcome:

    rows, exploits = [], []
    for result in results:
        frame = _history(result)
        exploits.extend(_exploits(frame, result))
        metrics = result.metrics or {}
        value = metrics.get(spec.metric, float("nan"))
        state = "error" if result.error is not None else "done"
        rows.append([metrics.get("trial_id", ""), state, value, metrics.get("training_iteration", ""),
                     *[result.config.get(k, "") for k in _keys(spec)]])
    scored = [r for r in rows if isinstance(r[2], (int, float)) and math.isfinite(r[2])]
    if not scored:
        errors = list(results.errors)
        if errors:
            last = " ".join(str(errors[0]).strip().splitlines()[-1:]).strip()[:300]
            raise ConfigError(spec.source, "trials", f"{len(errors)} of {len(rows)} trials failed, none finished "
                              f"an episode; the first: {last}")
        raise ConfigError(spec.source, "trials", "no trial reported a finished episode; raise "
                          "max_epochs_per_trial")
    best = (max if mode == "max" else min)(scored, key=lambda r: r[2])
    best_result = next(r for r in results if (r.metrics or {}).get("trial_id") == best[0])
    values = {k: best_result.config[k] for k in _keys(spec) if k in best_result.config}
    schedule_path = None
    if spec.ray.scheduler == "pbt":
        lineage = _lineage(best_result)
        if lineage:
            schedule_path = os.path.splitext(output)[0] + "_schedule.yaml"
            write_schedule_config(spec, lineage, schedule_path, float(best[2]), best[0])
    path, table_path = report(spec, _keys(spec), rows, output, (best[0], best[2]), values,
                              f"; {len(exploits)} PBT exploits" if spec.ray.scheduler == "pbt" else "", schedule_path)
    return SearchOutcome(float(best[2]), best[0], values, path, schedule_path, table_path, exploits, results)


def _keys(spec: Any) -> list[str]:
    mutations = spec.ray.pbt.mutations if spec.ray.pbt else {}
    return list(spec.params) + [k for k in mutations if k not in spec.params]


def _history(result: Any) -> Any:
    try:
        return result.metrics_dataframe
    except Exception:  # no progress file (a trial that never reported)
        return None


def _exploits(frame: Any, result: Any) -> list[dict]:
    if frame is None or "exploit" not in frame:
        return []
    out = []
    for text in frame["exploit"].dropna():
        if isinstance(text, str) and text:
            out.append({"trial": (result.metrics or {}).get("trial_id", ""), **json.loads(text)})
    return out


def _lineage(result: Any) -> list[list[Any]] | None:
    from rlchain.tuning.trainable import TRIAL_JSON  # optional: ray (trainable imports it)

    if result.checkpoint is None:
        return None
    with result.checkpoint.as_directory() as folder:
        path = os.path.join(folder, TRIAL_JSON)
        if not os.path.isfile(path):
            return None
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)["lineage"]


def write_schedule_config(spec: Any, lineage: list[list[Any]], output: str, value: float, trial: str) -> str:
    """The base config with the search's overrides, the winner's first values and its whole schedule
    as ``params.config.hyperparam_schedule`` (epochs done -> values): training it replays the schedule."""

    first = {f"params.config.{name}": item for name, item in lineage[0][1].items()}
    raw = apply_overrides(load_raw(spec.base), spec.overrides + override_strings(first), spec.base)
    raw["params"]["config"]["hyperparam_schedule"] = {int(epoch): dict(values) for epoch, values in lineage}
    with open(output, "w", encoding="utf-8") as fh:
        fh.write(f"# rlchain tune: the PBT schedule of the winner of {spec.source} (trial {trial}, "
                 f"{spec.metric} {value:.2f})\n# replay: {train_hint(output)}\n")
        for epoch, values in lineage:
            fh.write(f"#   from epoch {epoch}: " + ", ".join(f"{k}={fmt(v)}" for k, v in values.items()) + "\n")
        yaml.safe_dump(raw, fh, sort_keys=False)
    return output
