"""A short CartPole run under a pseudo-terminal shows the live status line (carriage return, ANSI erase,
ETA); the same run piped prints the plain epoch lines with no control characters."""

import os
import pty
import select
import sys
import threading

import pytest

from tests.conftest import CONFIGS, ROOT
from tests.smoke.cli_server import run_python, start_python

pytestmark = pytest.mark.smoke


def _command(train_dir):
    config = os.path.join(CONFIGS, "ppo_cartpole.yaml")
    return [sys.executable, os.path.join(ROOT, "runner.py"), "--train", "-f", config,
            "params.config.max_epochs=4", f"params.config.train_dir={train_dir}", "params.config.num_actors=4",
            "params.config.minibatch_size=64", "params.config.score_to_win=1e9"]


def _env():
    env = {k: v for k, v in os.environ.items() if k != "RLCHAIN_PROGRESS"}
    return {**env, "OMP_NUM_THREADS": "1", "TERM": "xterm"}


def _run_on_pty(command):
    """The command's standard output is a pseudo-terminal's (the child opens its slave by name); its text as the
    terminal received it. This process keeps the slave open (the child may open it after the command started), so
    the master is read until the command has ended, then drained."""
    master, slave = pty.openpty()
    ended, out = [], b""
    try:
        with start_python(command, ROOT, _env(), stdout=os.ttyname(slave)) as started:
            waiter = threading.Thread(target=lambda: ended.append(started.wait(120)))
            waiter.start()
            while True:
                done = not waiter.is_alive()  # what it wrote before it ended is read below
                while select.select([master], [], [], 0.05)[0]:
                    out += os.read(master, 4096)
                if done:
                    break
            waiter.join()
    finally:
        os.close(master)
        os.close(slave)
    assert ended and ended[0].returncode == 0, ended[0].stderr[-2000:] if ended else "the command did not end"
    return out.decode()


def test_terminal_shows_live_status_and_pipe_prints_plain_lines(tmp_path):
    live = _run_on_pty(_command(tmp_path / "tty"))
    assert "\r\x1b[K" in live  # redrawn in place
    assert "[############] epoch 4/4 | frames 256/" not in live  # max_frames is unset: no frame limit shown
    assert "[############] epoch 4/4 | frames 256 | " in live
    assert "ETA " in live and "fps" in live
    # the first and the last epoch lines above the status (the rest within 10 s are left to the status)
    assert "epoch 1/4 | frames 64 | fps " in live and "epoch 4/4 | frames 256 | fps " in live

    piped = run_python(_command(tmp_path / "pipe"), ROOT, _env(), 120)
    assert piped.returncode == 0, piped.stderr[-2000:]
    assert "\r" not in piped.stdout and "\x1b" not in piped.stdout and "ETA" not in piped.stdout
    epoch_lines = [line for line in piped.stdout.splitlines() if line.startswith("epoch ")]
    assert [line.split(" |")[0] for line in epoch_lines] == ["epoch 1/4", "epoch 2/4", "epoch 3/4", "epoch 4/4"]
