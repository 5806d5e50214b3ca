"""RLlib's example-script helper without ``--no-tune`` returns Tune's results (``get_best_result``, its checkpoint,
``get_dataframe``), one trial per ``tune.grid_search`` variant, as RLlib's checkpoint and inference examples read
them; ``check`` / ``check_learning_achieved`` assert as RLlib's do."""

import math
import os

import pytest
import torch

from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.core.rl_module import RLModule
from rlchain.rllib.examples.results import ResultGrid, TrialResult, grid_variants
from rlchain.rllib.examples.utils import add_rllib_example_script_args, run_rllib_example_script_experiment
from rlchain.rllib.utils.test_utils import check, check_learning_achieved


def _trial(returns, name="t"):
    return TrialResult(config={"name": name}, path=name,
                       history=[{"env_runners": {"episode_return_mean": r}, "training_iteration": i + 1}
                                for i, r in enumerate(returns)])


def test_grid_variants_are_every_combination_first_key_slowest():
    values = {"lr": {"grid_search": [1, 2]}, "gamma": {"grid_search": [0.9, 0.99]}, "x": 3}
    assert grid_variants(values) == [{"lr": 1, "gamma": 0.9}, {"lr": 1, "gamma": 0.99},
                                     {"lr": 2, "gamma": 0.9}, {"lr": 2, "gamma": 0.99}]
    assert grid_variants({"lr": 1e-3}) == [{}]
    with pytest.raises(ValueError, match="tune.grid_search for 'lr': expected a non-empty list"):
        grid_variants({"lr": {"grid_search": []}})


def test_get_best_result_compares_the_metric_over_its_scope():
    grid = ResultGrid([_trial([10, 50, 20], "a"), _trial([30, 30, 30], "b"), _trial([5, 6, 40], "c")], "exp")
    metric = "env_runners/episode_return_mean"
    assert grid.get_best_result(metric, "max").path == "c"  # last: 20, 30, 40
    assert grid.get_best_result(metric, "max", scope="all").path == "a"  # best ever: 50
    assert grid.get_best_result(metric, "min", scope="all").path == "c"  # lowest ever: 5
    assert grid.get_best_result(metric, "max", scope="avg").path == "b"  # 26.7, 30, 17
    with pytest.raises(ValueError, match="pass metric= and mode='max' or 'min'"):
        grid.get_best_result()
    with pytest.raises(RuntimeError, match="no trial reported 'nope'"):
        grid.get_best_result("nope", "max")
    one = ResultGrid([_trial([1.0])], "exp")
    assert one.get_best_result() is one[0] and len(one) == 1


def test_a_trials_metrics_and_dataframes_read_as_tunes():
    grid = ResultGrid([_trial([10, 50, 20], "a"), _trial([30, 35], "b")], "exp")
    assert grid[0].metrics["env_runners"]["episode_return_mean"] == 20 and grid[0].metrics["config"] == {"name": "a"}
    frame = grid[0].metrics_dataframe
    assert list(frame["env_runners/episode_return_mean"]) == [10, 50, 20] and "config/name" in frame
    last = grid.get_dataframe()
    assert list(last["env_runners/episode_return_mean"]) == [20, 35]
    best = grid.get_dataframe(filter_metric="env_runners/episode_return_mean", filter_mode="max")
    assert list(best["env_runners/episode_return_mean"]) == [50, 35]


def test_check_compares_structures_and_false_inverts():
    check({"a": [1.0, torch.tensor(2.0)]}, {"a": [1.0000001, 2.0]})
    check([1.0, 2.0], [1.0, 2.1], false=True)
    with pytest.raises(AssertionError):
        check({"a": 1.0}, {"a": 1.1})
    with pytest.raises(AssertionError):
        check([1.0], [1.0], false=True)
    check(1.0, 1.05, atol=0.1)


def test_check_learning_achieved_reads_every_trials_last_result():
    grid = ResultGrid([_trial([10, 50, 20]), _trial([30, 30])], "exp")
    check_learning_achieved(grid, 30.0)
    with pytest.raises(ValueError, match="of 31.0 not reached"):
        check_learning_achieved(grid, 31.0)
    check_learning_achieved({"env_runners": {"episode_return_mean": 5.0}}, 5.0)


def test_without_no_tune_the_helper_returns_results_with_checkpoints_per_grid_variant(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    args = add_rllib_example_script_args().parse_args(["--stop-iters=2", "--checkpoint-freq=1"])
    config = (PPOConfig().environment("CartPole-v1").debugging(seed=1)
              .training(lr={"grid_search": [1e-3, 1e-4]}, train_batch_size=32, minibatch_size=16, num_epochs=1))
    results = run_rllib_example_script_experiment(config, args)
    assert isinstance(results, ResultGrid) and len(results) == 2
    assert [r.config["lr"] for r in results] == [1e-3, 1e-4]
    assert all(r.metrics["training_iteration"] == 2 for r in results)
    best = results.get_best_result("env_runners/episode_return_mean", "max", scope="all")
    assert best.checkpoint.path.endswith("checkpoint_000001") and os.path.isdir(best.checkpoint.path)
    with best.checkpoint.as_directory() as folder:  # Tune's Checkpoint reads
        assert folder == best.checkpoint.to_directory() == best.checkpoint.path
    module = RLModule.from_checkpoint(os.path.join(best.checkpoint.path, "learner_group", "learner", "rl_module",
                                                   "default_policy"))
    logits = module.forward_inference({"obs": torch.zeros(1, 4)})["action_dist_inputs"]
    assert logits.shape == (1, 2) and not math.isnan(float(logits.sum()))
    last = run_rllib_example_script_experiment(config.copy().training(lr=1e-3),
                                               add_rllib_example_script_args().parse_args(["--stop-iters=1",
                                                                                           "--no-tune"]))
    assert isinstance(last, dict) and last["training_iteration"] == 1
