"""``ray.rllib.examples.utils``: RLlib's example-script helpers, run on the face.

:func:`add_rllib_example_script_args` adds RLlib's example flags (``--num-env-runners``, ``--stop-reward``,
``--stop-iters``, ``--stop-timesteps``, ``--as-test``, ...). :func:`run_rllib_example_script_experiment` applies
them to the config and trains in this process (``algo.train()`` until a stop value is reached; with or without
``--no-tune``: the face does not start Tune trials here), printing one line per iteration. As RLlib's, it returns
the last result with ``--no-tune`` and otherwise Tune's results (``get_best_result()``, its ``checkpoint.path``
from ``--checkpoint-freq`` / ``--checkpoint-at-end``), each ``tune.grid_search`` variant one trial, run one after
the other. ``--as-test`` fails (ValueError) when the stop reward was not reached, as RLlib's does.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from typing import Any

from rlchain.rllib.checkpoint_files import json_data
from rlchain.rllib.examples.results import Checkpoint, ResultGrid, TrialResult, checkpoint_folder, grid_variants
from rlchain.rllib.utils.metrics import (
    ENV_RUNNER_RESULTS,
    EPISODE_RETURN_MEAN,
    EVALUATION_RESULTS,
    NUM_ENV_STEPS_SAMPLED_LIFETIME,
    TRAINING_ITERATION,
)


def add_rllib_example_script_args(parser: argparse.ArgumentParser | None = None, default_reward: float = 100.0,
                                  default_iters: int = 200, default_timesteps: int = 100000
                                  ) -> argparse.ArgumentParser:
    """RLlib's example-script flags on ``parser`` (a new one when None)."""
    parser = parser or argparse.ArgumentParser()
    add = parser.add_argument
    add("--algo", type=str, default="PPO")
    add("--framework", choices=["tf", "tf2", "torch"], default="torch")
    add("--env", type=str, default=None)
    add("--num-env-runners", type=int, default=None)
    add("--num-envs-per-env-runner", type=int, default=None)
    add("--num-agents", type=int, default=0)
    add("--evaluation-num-env-runners", type=int, default=0)
    add("--evaluation-interval", type=int, default=0)
    add("--evaluation-duration", type=lambda v: v if v == "auto" else int(v), default=10)
    add("--evaluation-duration-unit", type=str, default="episodes", choices=["episodes", "timesteps"])
    add("--evaluation-parallel-to-training", action="store_true")
    add("--output", type=str, default=None)
    add("--log-level", type=str, default=None)
    add("--no-tune", action="store_true")
    add("--num-samples", type=int, default=1)
    add("--max-concurrent-trials", type=int, default=None)
    add("--verbose", type=int, default=2)
    add("--checkpoint-freq", type=int, default=0)
    add("--checkpoint-at-end", action="store_true")
    add("--tune-max-report-freq", type=int, default=5)
    add("--wandb-key", type=str, default=None)
    add("--wandb-project", type=str, default=None)
    add("--wandb-run-name", type=str, default=None)
    add("--stop-reward", type=float, default=default_reward)
    add("--stop-iters", type=int, default=default_iters)
    add("--stop-timesteps", type=int, default=default_timesteps)
    add("--as-test", action="store_true")
    add("--as-release-test", action="store_true")
    add("--num-learners", type=int, default=None)
    add("--num-cpus-per-learner", type=int, default=None)
    add("--num-gpus-per-learner", type=float, default=None)
    add("--num-aggregator-actors-per-learner", type=int, default=None)
    add("--num-cpus", type=int, default=0)
    add("--num-gpus", type=int, default=None)
    add("--old-api-stack", action="store_true")
    # flags RLlib 2.60 keeps out of --help only to refuse them (run_rllib_example_script_experiment)
    add("--enable-new-api-stack", action="store_true", help=argparse.SUPPRESS)
    add("--local-mode", action="store_true", help=argparse.SUPPRESS)
    return parser


def check_refused_flags(args: argparse.Namespace) -> None:
    """RLlib 2.60's ValueError, word for word, for the example flags it no longer takes."""
    if getattr(args, "enable_new_api_stack", False):
        raise ValueError("`--enable-new-api-stack` flag no longer supported (it's the default behavior now)! To "
                         "switch back to the old API stack on your scripts, use the `--old-api-stack` flag.")
    if getattr(args, "local_mode", False):
        raise ValueError("`--local-mode` is no longer supported.")


def _number(value: Any) -> str:
    """A result's value for the progress line: two decimals, ``-`` where the result has none (no episode ended
    yet: RLlib leaves the episode means out)."""
    return f"{value:.2f}" if isinstance(value, (int, float)) else "-"


def _lookup(result: dict[str, Any], path: str) -> Any:
    node: Any = result
    for part in path.split("/"):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def run_rllib_example_script_experiment(base_config: Any, args: argparse.Namespace | None = None, *,
                                        stop: dict[str, Any] | None = None, success_metric: dict | None = None,
                                        trainable: Any = None, tune_callbacks: Any = None,
                                        keep_config: bool = False, keep_ray_up: bool = False, scheduler: Any = None,
                                        progress_reporter: Any = None) -> Any:
    """Train ``base_config`` (with ``args`` applied) until a ``stop`` value is reached: with ``--no-tune`` the
    last result, as RLlib's; else a Tune ``ResultGrid`` of one trial per ``tune.grid_search`` variant
    (:mod:`rlchain.rllib.examples.results`)."""
    args = args or add_rllib_example_script_args().parse_args([])
    check_refused_flags(args)
    if getattr(args, "as_release_test", False):  # RLlib: a release test is a test
        args.as_test = True
    config = base_config
    if not keep_config:
        if args.env is not None and config.get("env") is None:
            config.environment(args.env)
        if args.num_env_runners is not None:
            config.env_runners(num_env_runners=args.num_env_runners)
        if args.num_envs_per_env_runner is not None:
            config.env_runners(num_envs_per_env_runner=args.num_envs_per_env_runner)
        if args.num_learners is not None:
            config.learners(num_learners=args.num_learners)
        if args.num_gpus_per_learner:
            config.learners(num_gpus_per_learner=args.num_gpus_per_learner)
        if args.evaluation_interval:
            config.evaluation(evaluation_interval=args.evaluation_interval,
                              evaluation_duration=args.evaluation_duration,
                              evaluation_duration_unit=args.evaluation_duration_unit)
    stop = stop or {f"{ENV_RUNNER_RESULTS}/{EPISODE_RETURN_MEAN}": args.stop_reward,
                    NUM_ENV_STEPS_SAMPLED_LIFETIME: args.stop_timesteps, TRAINING_ITERATION: args.stop_iters}
    success_metric = success_metric or {f"{ENV_RUNNER_RESULTS}/{EPISODE_RETURN_MEAN}": args.stop_reward}
    if args.no_tune:
        result = _train_trial(config, args, stop, None)
        _check_success([result.history[-1] if result.history else {}], success_metric, args)
        return result.history[-1] if result.history else {}
    experiment = tempfile.mkdtemp(prefix=f"{config.algo_name}_")
    trials = []
    for index, variant in enumerate(grid_variants(config.to_dict())):
        trial_config = config.copy(copy_frozen=False).update_from_dict(variant) if variant else config
        trial = TrialResult(config=json_data(trial_config.to_dict()),
                            path=os.path.join(experiment, f"{config.algo_name}_{index:05d}"))
        os.makedirs(trial.path)
        if len(variant):
            print(f"trial {index}: {variant}", flush=True)
        trials.append(_train_trial(trial_config, args, stop, trial))
    _check_success([t.history[-1] for t in trials if t.history], success_metric, args)
    return ResultGrid(trials, experiment)


def _train_trial(config: Any, args: argparse.Namespace, stop: dict[str, Any], trial: TrialResult | None
                 ) -> TrialResult:
    """Train ``config`` until a ``stop`` value is reached; every result in the trial's history and, for a Tune
    trial (``trial`` given), a checkpoint every ``--checkpoint-freq`` iterations and at the end
    (``--checkpoint-at-end``) in Tune's folder names."""
    out = trial or TrialResult(config={}, path="")
    # RLlib's --no-tune loop runs stop's training_iteration (or --stop-iters) iterations at most, even when the
    # script's own stop dict has no iteration count; under Tune only the stop dict stops the trial
    iterations = stop.get(TRAINING_ITERATION, args.stop_iters) if args.no_tune else None
    algo = config.build_algo()
    start = time.time()
    saved = -1
    try:
        while iterations is None or len(out.history) < iterations:
            result = algo.train()
            out.history.append(result)
            ret = _number(_lookup(result, f"{ENV_RUNNER_RESULTS}/{EPISODE_RETURN_MEAN}"))
            line = (f"iter {result[TRAINING_ITERATION]}: {EPISODE_RETURN_MEAN} {ret}, env steps "
                    f"{result[NUM_ENV_STEPS_SAMPLED_LIFETIME]}, {time.time() - start:.1f} s")
            evaluation = result.get(EVALUATION_RESULTS)
            if evaluation:
                line += f", evaluation {_number(_lookup(evaluation, f'{ENV_RUNNER_RESULTS}/{EPISODE_RETURN_MEAN}'))}"
            if args.verbose:
                print(line, flush=True)
            if trial is not None and args.checkpoint_freq and algo.iteration % args.checkpoint_freq == 0:
                saved = algo.iteration
                out.checkpoint = Checkpoint(algo.save_to_path(checkpoint_folder(trial.path, len(out.history) - 1)))
            if any(isinstance(v := _lookup(result, key), (int, float)) and v >= target
                   for key, target in stop.items() if target is not None):
                break
        if args.checkpoint_at_end and saved != algo.iteration:
            folder = checkpoint_folder(trial.path, len(out.history) - 1) if trial is not None else None
            out.checkpoint = Checkpoint(algo.save_to_path(folder))
            print(f"checkpoint: {out.checkpoint.path}", flush=True)
    finally:
        algo.stop()
    return out


def _check_success(results: list[dict[str, Any]], success_metric: dict[str, Any], args: argparse.Namespace
                   ) -> None:
    """``--as-test``: a ValueError unless some trial's last result reached every ``success_metric`` value."""
    if not args.as_test:
        return
    for key, target in success_metric.items():
        values = [v for r in results if isinstance(v := _lookup(r, key), (int, float))]
        if not values or max(values) < target:
            raise ValueError(f"`{key}` of {target} not reached (got {max(values) if values else None})")
        print(f"`{key}` of {target} reached", flush=True)
