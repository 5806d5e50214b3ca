"""The live status line (rlchain/runs/progress.py) and the console writer's choice of lines."""

import io
import logging

import pytest

from rlchain.config import ConfigError
from rlchain.config.run import ProgressConfig
from rlchain.log import get_logger
from rlchain.runs import progress
from rlchain.runs.writers import ConsoleWriter, EpochSummary, epoch_line


class Terminal(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self):
        return True


def summary(epoch, frames, seconds, max_epochs=10, max_frames=0, reward=1.5, success=None):
    return EpochSummary(epoch, max_epochs, frames, seconds, 100.0, 200.0, reward, 9.0, success, reward, (),
                        max_frames)


def test_durations_and_counts():
    assert progress.format_duration(42.9) == "42s"
    assert progress.format_duration(307) == "5:07"
    assert progress.format_duration(3723) == "1:02:03"
    assert {progress.format_duration(x) for x in (None, float("inf"), -1)} == {"?"}
    assert progress.format_count(950) == "950"
    assert progress.format_count(24_600) == "24.6k"
    assert progress.format_count(123_456) == "123k"
    assert progress.format_count(999_600) == "1M"
    assert progress.format_count(1_200_000) == "1.2M"
    assert progress.format_count(3e9) == "3G"
    assert progress.format_value(12345.6) == "12346" and progress.format_value(-0.012345) == "-0.01235"


def test_eta_is_the_remaining_work_at_this_process_average_rate():
    # 20 of 100 epochs in 10 s since epoch 10 (a resume at 10): 10 epochs per 10 s -> 80 left = 80 s
    assert progress.eta_seconds(20, 100, 10, 10.0) == pytest.approx(80.0)
    assert progress.eta_seconds(100, 100, 10, 10.0) == 0.0
    assert progress.eta_seconds(5, -1, 0, 10.0) is None  # no limit
    assert progress.eta_seconds(10, 100, 10, 10.0) is None  # no progress yet
    # the frame limit comes first: 1000 of 4000 frames in 5 s (600 s by epochs, 15 s by frames)
    assert progress.run_eta(10, 1000, 1000, 4000, 5, 0, 5.0) == pytest.approx(15.0)
    assert progress.run_eta(10, -1, 1000, -1, 5, 0, 5.0) is None
    assert progress.fraction_done(10, 100, 3000, 4000) == pytest.approx(0.75)
    assert progress.fraction_done(3, 0, 10, 0) is None


def test_status_line_shows_limit_rate_reward_success_and_eta():
    line = progress.status_line(progress.StatusFields(12, 100, 24_600, 200_000, 1234.0, 123.44, 0.45, 42.0, 310.0))
    assert line.startswith("[#...........] epoch 12/100 | frames 24.6k/200k | 1.23k fps | reward 123.4 | ")
    assert line.endswith("success 0.45 | 42s | ETA 5:10")
    bare = progress.status_line(progress.StatusFields(3, 0, 96, 0, 50.0, None, None, 1.0, None))
    assert bare == "epoch 3 | frames 96 | 50 fps | reward - | 1s | ETA ?"
    assert progress.fit("x" * 200, 80) == "x" * 78 + "~" and progress.fit("short", 80) == "short"


def test_live_only_on_a_terminal_unless_forced():
    assert progress.live_wanted(None, Terminal(), {"TERM": "xterm"})
    assert not progress.live_wanted(None, io.StringIO(), {"TERM": "xterm"})
    assert not progress.live_wanted(None, Terminal(), {"TERM": "dumb"})
    assert not progress.live_wanted(False, Terminal(), {})
    assert progress.live_wanted(True, io.StringIO(), {})
    assert not progress.live_wanted(True, Terminal(), {"RLCHAIN_PROGRESS": "off"})
    assert progress.live_wanted(None, io.StringIO(), {"RLCHAIN_PROGRESS": "1"})


def test_plain_stream_prints_every_epoch_line_as_before():
    out = io.StringIO()
    writer = ConsoleWriter(out, ProgressConfig())
    for epoch in range(1, 4):
        writer.epoch_end(summary(epoch, epoch * 64, epoch * 0.5))
    writer.close()
    lines = out.getvalue().splitlines()
    assert lines == [epoch_line(summary(e, e * 64, e * 0.5)) for e in range(1, 4)]
    assert lines[0] == "epoch 1/10 | frames 64 | fps 100 (step 200) | reward 1.50 | best 1.50 | len 9.0 | 0s"
    assert "\x1b" not in out.getvalue() and "\r" not in out.getvalue()


def test_live_status_throttles_epoch_lines_and_prints_the_last(monkeypatch):
    monkeypatch.setenv("TERM", "xterm")
    monkeypatch.setenv("COLUMNS", "200")  # wide enough for the whole status line, whatever runs the tests
    monkeypatch.delenv(progress.ENV_VAR, raising=False)
    out = Terminal()
    monkeypatch.setattr("sys.stdout", out)  # rlchain's log messages go to the stdout of the moment
    writer = ConsoleWriter(out, ProgressConfig(print_every_seconds=2.0))
    for epoch in range(1, 8):  # one epoch a second, no limit reached
        writer.epoch_end(summary(epoch, epoch * 64, float(epoch), max_epochs=100, success=0.25))
    get_logger("rlchain.test").info("a message")  # printed above the status, which is drawn again
    text = out.getvalue()
    printed = [line for line in text.replace(progress.ERASE_LINE, "\n").splitlines() if line.startswith("epoch ")]
    assert [line.split(" |")[0] for line in printed] == ["epoch 1/100", "epoch 3/100", "epoch 5/100", "epoch 7/100"]
    assert text.endswith(progress.ERASE_LINE + "a message\n" + progress.ERASE_LINE + writer.live.text)
    # 6 epochs in 6 s since the first: 93 left -> 93 s
    assert writer.live.text.endswith("success 0.25 | 7s | ETA 1:33")
    writer.epoch_end(summary(8, 512, 8.0, max_epochs=100))  # not due: pending, printed when the run ends
    writer.close()
    assert out.getvalue().endswith(progress.ERASE_LINE + epoch_line(summary(8, 512, 8.0, max_epochs=100)) + "\n")
    logging.getLogger("rlchain.test").info("after the run")  # no status left to redraw
    assert out.getvalue().endswith("\n")


def test_bad_progress_values_are_config_errors():
    from rlchain.config.load import parse_params

    def config(block):
        return {"params": {"algo": {"name": "a2c_discrete"}, "model": {"name": "discrete_a2c"},
                           "network": {"name": "actor_critic", "mlp": {"units": [8]}, "space": {"discrete": {}}},
                           "config": {"env_name": "CartPole-v1", "minibatch_size": 64, "progress": block}}}

    with pytest.raises(ConfigError, match=r"cfg.yaml: params.config.progress.print_every_epochs: must be > 0, got 0"):
        parse_params(config({"print_every_epochs": 0}), "cfg.yaml")
    with pytest.raises(ConfigError, match=r"progress.lives: unknown key; did you mean 'live'"):
        parse_params(config({"lives": True}), "cfg.yaml")
    with pytest.raises(ConfigError, match=r"progress.print_every_seconds: must be >= 0"):
        parse_params(config({"print_every_seconds": -1}), "cfg.yaml")


def test_the_config_block_reaches_the_console_writer(monkeypatch):
    from rlchain.config.load import parse_params
    from rlchain.runs.logging import TrainLogger

    monkeypatch.setenv("TERM", "xterm")
    monkeypatch.setenv("COLUMNS", "200")  # wide enough for the whole status line, whatever runs the tests
    monkeypatch.delenv(progress.ENV_VAR, raising=False)
    raw = {"params": {"algo": {"name": "a2c_discrete"}, "model": {"name": "discrete_a2c"},
                      "network": {"name": "actor_critic", "mlp": {"units": [8]}, "space": {"discrete": {}}},
                      "config": {"env_name": "CartPole-v1", "minibatch_size": 64,
                                 "progress": {"live": False, "print_every_epochs": 5}}}}
    cfg = parse_params(raw, "cfg.yaml").config
    assert cfg.progress == ProgressConfig(live=False, print_every_epochs=5)
    console = TrainLogger(None, True, stream=Terminal(), progress=cfg.progress).writers[0]
    assert console.live is None and console.every_epochs == 5
    auto = TrainLogger(None, True, stream=Terminal(), progress=ProgressConfig()).writers[0]
    assert auto.live is not None and auto.every_seconds == progress.DEFAULT_LIVE_SECONDS
    assert TrainLogger(None, True, stream=Terminal()).writers[0].live is None  # no block given: tuning, tests
