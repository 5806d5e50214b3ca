"""Log writers (rlchain/runs/writers.py): a user's own gets every scalar TensorBoard gets; CSV; bad names."""

import csv
import glob
import os
from collections import Counter

import pytest
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from rlchain import Runner
from rlchain.config import ConfigError
from rlchain.runs.writers import Writer, register_writer
from rlchain.training.events import Callback
from tests.conftest import CONFIGS
from tests.smoke.test_train_play_resume import small

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
RECORDED = []


class Recorder(Writer):
    """A user's writer: keeps every (tag, value, x) it is given."""

    def __init__(self, run_dir):
        self.run_dir = run_dir
        self.closed = False
        RECORDED.append(self)
        self.rows = []

    def write(self, scalars, step):
        self.rows += [(tag, value, step.x(tag)) for tag, value in scalars.items()]

    def close(self):
        self.closed = True


class SeesTags(Callback):
    def __init__(self):
        self.seen = []

    def on_epoch_end(self, ctx, stats, episodes):
        self.seen.append(dict(ctx.state.scalars))
        ctx.writer.add_scalar("custom/from_callback", 1.5)


@pytest.fixture
def recorder(scoped_registries):
    register_writer("recorder", Recorder)
    RECORDED.clear()


def tensorboard_scalars(run_dir):
    acc = EventAccumulator(os.path.join(run_dir, "summaries"), size_guidance={"scalars": 0})
    acc.Reload()
    return [(tag, event.value, event.step) for tag in acc.Tags()["scalars"] for event in acc.Scalars(tag)]


def test_user_writer_gets_every_scalar_tensorboard_gets(tmp_path, recorder):
    callback = SeesTags()
    result = Runner().load(CARTPOLE, small(tmp_path, extra=["params.config.log_writers=[recorder, csv]"])) \
        .train(callbacks=[callback])
    (writer,) = RECORDED
    assert writer.run_dir == result.run_dir and writer.closed
    board = tensorboard_scalars(result.run_dir)
    assert Counter(tag for tag, _, _ in writer.rows) == Counter(tag for tag, _, _ in board)
    assert sorted((tag, x) for tag, _, x in writer.rows) == sorted((tag, step) for tag, _, step in board)
    tags = {tag for tag, _, _ in board}
    assert {"rewards/step", "rewards/iter", "rewards/time", "losses/a_loss", "performance/step_fps",
            "custom/from_callback"} <= tags
    # callbacks see the epoch's scalars under the same tags
    assert len(callback.seen) == 2 and {"rewards/step", "losses/a_loss", "info/epochs"} <= set(callback.seen[-1])
    # the CSV writer: a readable file with the same scalars
    with open(os.path.join(result.run_dir, "summaries", "scalars.csv")) as fh:
        rows = list(csv.DictReader(fh))
    assert Counter(row["tag"] for row in rows) == Counter(tag for tag, _, _ in board)
    last = [row for row in rows if row["tag"] == "info/epochs"][-1]
    assert float(last["value"]) == 2 and int(last["epoch"]) == 2 and int(last["frames"]) == 1024


def test_unknown_writer_is_one_line_with_did_you_mean(tmp_path):
    with pytest.raises(ConfigError) as err:
        Runner().load(CARTPOLE, small(tmp_path, extra=["params.config.log_writers=[cvs]"])).train()
    text = str(err.value)
    assert text.startswith(f"{CARTPOLE}: params.config.log_writers[0]: unknown log writer 'cvs'; "
                           f"did you mean 'csv'?") and "registered: csv" in text and "\n" not in text
    assert not glob.glob(str(tmp_path / "runs" / "*"))  # no run folder left behind
