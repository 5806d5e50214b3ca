"""EpochStepper (rlchain/tuning/epochs.py) on a live run: a Ray actor reused for another trial moves its run."""

import os

import pytest

from rlchain import Runner
from rlchain.tuning.epochs import EpochStepper
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke


def test_a_live_run_moves_with_its_checkpoint_names(tmp_path):
    """A Ray actor reused for another trial: the parked run goes on in the new folder, rl_games' file names kept."""
    runner = Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml"), [
        "params.config.print_stats=false", f"params.config.train_dir={tmp_path}", "params.config.max_epochs=3",
        "params.config.num_actors=4", "params.config.minibatch_size=64", "params.config.full_experiment_name=trial_1"])
    runner.layout = "rl_games"  # as rlchain.rl_games' Runner sets it
    stepper = EpochStepper(runner, seed=1)
    try:
        assert stepper.next_epoch().epoch == 1
        stepper.move_run("trial_2")
        assert stepper.context.run_dir.layout == "rl_games"
        while stepper.next_epoch() is not None:
            pass
    finally:
        stepper.shutdown()
    moved = os.path.join(str(tmp_path), "trial_2")
    assert stepper.result.run_dir == moved
    assert any(f.startswith("last_cartpole_ep_3") for f in os.listdir(os.path.join(moved, "nn")))  # rl_games' name
    assert any(f.startswith("events.out") for f in os.listdir(os.path.join(moved, "summaries")))
