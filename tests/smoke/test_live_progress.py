"""A short CartPole run under a pseudo-terminal shows the live status line (carriage return, ANSI erase,
ETA); the same run piped prints the plain epoch lines with no control characters."""

import os
import pty
import subprocess
import sys

import pytest

from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke
ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def _command(train_dir):
    config = os.path.join(CONFIGS, "ppo_cartpole.yaml")
    return [sys.executable, os.path.join(ROOT, "runner.py"), "--train", "-f", config,
            "params.config.max_epochs=4", f"params.config.train_dir={train_dir}", "params.config.num_actors=4",
            "params.config.minibatch_size=64", "params.config.score_to_win=1e9"]


def _env():
    env = {k: v for k, v in os.environ.items() if k != "RLCHAIN_PROGRESS"}
    return {**env, "OMP_NUM_THREADS": "1", "TERM": "xterm"}


def _run_on_pty(command):
    master, slave = pty.openpty()
    proc = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=slave, stderr=subprocess.PIPE, env=_env(),
                            cwd=ROOT)
    os.close(slave)
    out = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # EIO: the child closed the terminal
            break
        if not chunk:
            break
        out += chunk
    os.close(master)
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0, err[-2000:]
    return out.decode()


def test_terminal_shows_live_status_and_pipe_prints_plain_lines(tmp_path):
    live = _run_on_pty(_command(tmp_path / "tty"))
    assert "\r\x1b[K" in live  # redrawn in place
    assert "[############] epoch 4/4 | frames 256/" not in live  # max_frames is unset: no frame limit shown
    assert "[############] epoch 4/4 | frames 256 | " in live
    assert "ETA " in live and "fps" in live
    # the first and the last epoch lines above the status (the rest within 10 s are left to the status)
    assert "epoch 1/4 | frames 64 | fps " in live and "epoch 4/4 | frames 256 | fps " in live

    piped = subprocess.run(_command(tmp_path / "pipe"), capture_output=True, text=True, env=_env(), cwd=ROOT,
                           timeout=120)
    assert piped.returncode == 0, piped.stderr[-2000:]
    assert "\r" not in piped.stdout and "\x1b" not in piped.stdout and "ETA" not in piped.stdout
    epoch_lines = [line for line in piped.stdout.splitlines() if line.startswith("epoch ")]
    assert [line.split(" |")[0] for line in epoch_lines] == ["epoch 1/4", "epoch 2/4", "epoch 3/4", "epoch 4/4"]

