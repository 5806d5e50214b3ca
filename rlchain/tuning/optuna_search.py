"""Hyperparameter search with Optuna (``pip install rlchain[tune]``): the trials train in this process
with ``Runner().load(base, overrides).train()``; each epoch's mean reward is reported to Optuna and bad
trials stop early (MedianPruner). The search file is described in :mod:`rlchain.tuning.common`.
"""

from __future__ import annotations

import math
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.runner import Runner
from rlchain.training.callback_context import CallbackContext
from rlchain.training.events import Callback
from rlchain.tuning.common import SearchSpec, check_space, fmt, import_optuna, override_strings, report, study_folder


def suggest(trial: Any, spec: SearchSpec) -> dict[str, Any]:
    """Sample one value per searched key."""
    values = {}
    for key, dist in spec.params.items():
        if dist["type"] == "categorical":
            values[key] = trial.suggest_categorical(key, dist["choices"])
        elif dist["type"] == "int":
            values[key] = trial.suggest_int(key, dist["low"], dist["high"], step=dist.get("step", 1),
                                            log=dist["log"])
        else:
            values[key] = trial.suggest_float(key, dist["low"], dist["high"], step=dist.get("step"),
                                              log=dist["log"])
    return values


class PruningCallback(Callback):
    """Reports each epoch's mean reward (or best so far) to the trial; asks the run to stop when pruned."""

    def __init__(self, trial: Any, metric: str) -> None:
        self.trial = trial
        self.metric = metric
        self.best = float("-inf")
        self.pruned = False

    def on_epoch_end(self, ctx: CallbackContext, stats: dict, episodes: dict | None) -> None:
        if episodes is None or self.pruned:
            return
        value = float(episodes["reward"])
        self.best = max(self.best, value)
        self.trial.report(self.best if self.metric == "best_reward" else value, ctx.state.epoch)
        if self.trial.should_prune():
            self.pruned = True
            ctx.request_stop("optuna pruner")


def run_optuna_search(spec: SearchSpec, output: str | None = None,
                      train_dir: str | None = None) -> tuple[float, str]:
    """The search on Optuna (trials in this process); returns (best value, path of the best config)."""
    optuna = import_optuna()
    check_space(spec)
    base_params = Runner().load(spec.base, spec.overrides).params
    study_dir, output = study_folder(spec, train_dir or base_params.config.train_dir, output)
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    pruner = optuna.pruners.NopPruner() if spec.pruner is None else optuna.pruners.MedianPruner(
        **{"n_startup_trials": 2, "n_warmup_steps": max(1, (spec.max_epochs_per_trial or 20) // 5),
           **spec.pruner})
    study = optuna.create_study(direction=spec.direction, pruner=pruner,
                                sampler=optuna.samplers.TPESampler(seed=spec.seed))
    print(f"rlchain tune: {spec.trials} trials of {spec.base}, {spec.direction} {spec.metric} "
          f"-> {study_dir}", flush=True)

    def objective(trial: Any) -> float:
        values = suggest(trial, spec)
        overrides = [*spec.trial_overrides(study_dir, override_strings(values)),
                     f"params.config.full_experiment_name=trial_{trial.number:03d}"]
        callback = PruningCallback(trial, spec.metric)
        result = Runner().load(spec.base, overrides).train(callbacks=[callback])
        value = float(getattr(result, spec.metric))
        trial.set_user_attr("epochs", result.epoch)
        trial.set_user_attr("run_dir", result.run_dir)
        shown = ", ".join(f"{k.removeprefix('params.config.')}={fmt(v)}" for k, v in values.items())
        state = "pruned" if callback.pruned else "done"
        print(f"trial {trial.number}: {state} at epoch {result.epoch}, {spec.metric} {value:.2f} ({shown})",
              flush=True)
        if callback.pruned:
            raise optuna.TrialPruned()
        if not math.isfinite(value):  # no finished episode: a failed trial, not a best candidate
            return float("-inf") if spec.direction == "maximize" else float("inf")
        return value

    study.optimize(objective, n_trials=spec.trials, timeout=spec.timeout, catch=())
    complete = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    if not complete:
        raise ConfigError(spec.source, "trials", "no trial completed (all pruned or without a finished "
                          "episode); loosen the pruner or raise max_epochs_per_trial")
    best = study.best_trial
    path, _ = report(spec, list(spec.params), trial_rows(study, spec), output, (best.number, best.value), best.params)
    return float(best.value), path


def trial_rows(study: Any, spec: SearchSpec) -> list[list[str]]:
    """Every trial's row for :func:`rlchain.tuning.common.report` (a pruned trial shows its last reported
    value in parentheses)."""
    rows = []
    for t in study.trials:
        value = "" if t.value is None else f"{t.value:.2f}"
        if t.value is None and t.intermediate_values:
            value = f"({t.intermediate_values[max(t.intermediate_values)]:.2f})"
        rows.append([str(t.number), t.state.name.lower(), value, str(t.user_attrs.get("epochs", ""))]
                    + [fmt(t.params.get(k, "")) for k in spec.params])
    return rows
