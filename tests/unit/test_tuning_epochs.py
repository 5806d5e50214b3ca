"""EpochStepper (rlchain/tuning/epochs.py) without training: moving a parked run to another run folder."""

import os
from types import SimpleNamespace

import pytest

from rlchain.runs.logging import TrainLogger
from rlchain.runs.run_dir import RunDir, create_run_dir
from rlchain.tuning.epochs import EpochStepper


class ParkedRun:
    """The parts of a CallbackContext that ``move_run`` reads, with the run moved into ``moved``."""

    def __init__(self, train_dir: str, layout: str) -> None:
        self.params = SimpleNamespace(config=SimpleNamespace(train_dir=train_dir, name="cartpole", print_stats=False,
                                                             log_writers=[]))
        self.raw_config = {"params": {"config": {"name": "cartpole"}}}
        self.run_dir = create_run_dir(train_dir, "cartpole", "trial_1", self.raw_config, layout=layout)
        self.logger = TrainLogger(None, print_stats=False)

    def move_run(self, run: RunDir, logger: TrainLogger) -> TrainLogger:
        old, self.run_dir, self.logger = self.logger, run, logger
        return old


@pytest.mark.parametrize("layout", ["rl_games", "embodichain", "rlchain"])
def test_moved_run_keeps_the_checkpoint_names_of_its_layout(tmp_path, layout):
    run = ParkedRun(str(tmp_path), layout)
    stepper = EpochStepper(runner=None)
    stepper.context = run
    stepper.move_run("trial_2")
    try:
        moved = run.run_dir
        assert moved.root == os.path.join(str(tmp_path), "trial_2") and os.path.isdir(moved.nn)
        assert moved.layout == layout
        assert moved.checkpoint("best") == RunDir(moved.root, "cartpole", layout).checkpoint("best")
    finally:
        run.logger.close()
