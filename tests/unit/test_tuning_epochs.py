"""EpochStepper (rlchain/tuning/epochs.py) without training: moving a parked run to another run folder."""

import io
import os
from types import SimpleNamespace

import pytest

from rlchain.config.run import ProgressConfig
from rlchain.runs.logging import TrainLogger
from rlchain.runs.rl_games_layout import RlGamesTags
from rlchain.runs.run_dir import RunDir, create_run_dir
from rlchain.tuning.epochs import EpochStepper


class ParkedRun:
    """The parts of a CallbackContext that ``move_run`` reads; its move keeps what the context's does."""

    def __init__(self, train_dir: str, layout: str, logger: TrainLogger) -> None:
        self.params = SimpleNamespace(config=SimpleNamespace(train_dir=train_dir, name="cartpole", print_stats=True,
                                                             log_writers=["csv"]))
        self.raw_config = {"params": {"config": {"name": "cartpole"}}}
        self.run_dir = create_run_dir(train_dir, "cartpole", "trial_1", self.raw_config, layout=layout)
        self.logger = logger

    def move_run(self, run: RunDir, writers: list) -> TrainLogger:
        self.logger, self.run_dir = self.logger.moved(run.summaries, writers), run
        return self.logger


@pytest.mark.parametrize("layout", ["rl_games", "embodichain", "rlchain"])
def test_moved_run_keeps_the_checkpoint_names_of_its_layout(tmp_path, layout):
    run = ParkedRun(str(tmp_path), layout, TrainLogger(None, print_stats=False))
    stepper = EpochStepper(runner=None)
    stepper.context = run
    stepper.move_run("trial_2")
    try:
        moved = run.run_dir
        assert moved.root == os.path.join(str(tmp_path), "trial_2") and os.path.isdir(moved.nn)
        assert moved.layout == layout
        assert moved.checkpoint("best") == RunDir(moved.root, "cartpole", layout).checkpoint("best")
        assert stepper._moved_logger is run.logger  # the stepper closes it at shutdown
        assert os.path.isfile(os.path.join(moved.summaries, "scalars.csv"))  # the new folder's own writers
    finally:
        run.logger.close()


def test_a_moved_logger_keeps_the_console_progress_and_rl_games_tags(tmp_path):
    stream, tags, progress = io.StringIO(), RlGamesTags(0.2, 1.0, 0.0, True), ProgressConfig(live=False)
    old = TrainLogger(None, print_stats=True, stream=stream, progress=progress, rl_games=tags)
    new = old.moved(str(tmp_path / "summaries"), [])
    try:
        assert (new.print_stats, new.stream, new.progress, new.rl_games) == (True, stream, progress, tags)
        assert new.tensorboard is not None and new.writers[-1] is new.tensorboard
    finally:
        new.close()

