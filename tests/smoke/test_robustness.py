"""Runs that survive: signals, crash-safe checkpoints, divergence, broken envs, disk errors."""

import glob
import logging
import os
import re
import signal
import subprocess
import sys
import textwrap
import time

import pytest
import torch

import tests.smoke.broken_envs  # noqa: F401  (registers the broken envs)
from rlchain import Runner
from rlchain.algos.base.safety import StopSignals
from rlchain.errors import DivergenceError, EnvError
from rlchain.runs import checkpoint as ckpt
from rlchain.training.events import Callback
from tests.conftest import CONFIGS, ROOT
from tests.smoke.cli_server import start_python
from tests.smoke.test_train_play_resume import run_cli, small

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")


def cartpole(tmp_path, *extra, epochs=3):
    return Runner().load(CARTPOLE, small(tmp_path, epochs=epochs, extra=["params.config.print_stats=false",
                                                                          *extra]))


def test_sigterm_saves_and_resume_continues(tmp_path):
    """``python runner.py --train`` in a child of the fork server (tests/smoke/cli_server.py), a process and
    session of its own as a fresh ``python`` is: SIGTERM once its 5th epoch has printed."""
    env = dict(os.environ, PYTHONPATH=ROOT)
    argv = [sys.executable, os.path.join(ROOT, "runner.py"), "--train", "--file", CARTPOLE,
            *small(tmp_path, epochs=100000)]
    with start_python(argv, tmp_path, env) as started:
        deadline = time.time() + 120
        while not re.search(r"^epoch 5/", started.output(), re.MULTILINE) and time.time() < deadline:
            time.sleep(0.05)
        os.kill(started.pid, signal.SIGTERM)
        ended = started.wait(60)
    text = ended.stdout + ended.stderr
    assert ended.returncode == 143, text  # 128 + SIGTERM, as a shell reports a terminated process
    assert "interrupted by SIGTERM" in text
    assert f"resume with: python runner.py --train --file {CARTPOLE} --checkpoint " in text  # the real path
    last = glob.glob(str(tmp_path / "runs" / "cartpole_*" / "nn" / "last_cartpole.pth"))[0]
    epoch = ckpt.load(last)["epoch"]
    assert epoch >= 5
    resumed = run_cli(["--train", "--file", CARTPOLE, "--checkpoint", last, *small(tmp_path, epochs=epoch + 2)],
                      tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert f"at epoch {epoch}" in resumed.stdout and f"epoch {epoch + 1}/{epoch + 2}" in resumed.stdout


def _wait_for(condition, seconds=10.0):
    """Let the main thread reach its next signal check: a signal sent to the process may be received
    by another thread (Ray, envpool, OpenMP, TensorBoard writers), and Python runs the handler in the
    main thread at its next check, not necessarily before the line after os.kill."""
    deadline = time.monotonic() + seconds
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.001)
    return condition()


def test_second_signal_exits_at_once():
    previous = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    with StopSignals() as signals:
        os.kill(os.getpid(), signal.SIGINT)
        assert _wait_for(lambda: signals.requested is not None)
        assert signals.requested == "SIGINT"
        with pytest.raises(KeyboardInterrupt, match="second SIGTERM"):
            os.kill(os.getpid(), signal.SIGTERM)
            _wait_for(lambda: False)
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == previous


def test_a_stop_asked_for_in_code_is_not_an_interruption():
    """A callback's (or a pruner's) request_stop ends the run as finished: no 'interrupted', no exit
    130, no resume line; a user's Ctrl-C after it is still a first signal, not an exit at once."""
    with StopSignals() as signals:
        signals.request("optuna pruner")
        signals.request("later")  # the first reason stays
        assert signals.stop_reason() == "stopped by request: optuna pruner"
        os.kill(os.getpid(), signal.SIGINT)  # must not raise KeyboardInterrupt
        assert _wait_for(lambda: signals.by_signal)
        assert signals.stop_reason() == "interrupted by SIGINT"


def test_callback_stop_prints_no_resume_line(tmp_path, caplog):
    class Stop(Callback):
        def on_epoch_end(self, ctx, stats, episodes):
            ctx.request_stop("enough")

    with caplog.at_level(logging.INFO, logger="rlchain"):
        result = cartpole(tmp_path, epochs=5).train(callbacks=[Stop()])
    assert result.stop_reason == "stopped by request: enough" and result.epoch == 1
    assert "resume with" not in caplog.text and "stopped:" not in caplog.text
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="rlchain"):
        cartpole(tmp_path, "params.config.print_stats=true", epochs=5).train(callbacks=[Stop()])
    assert "stopped by request: enough at epoch 1" in caplog.text and "stopped: stopped" not in caplog.text
    assert "resume with" not in caplog.text


def test_signals_in_a_fresh_process_with_threads():
    """The same two-signal contract in a process of its own, with busy non-main threads that could
    receive the signal (as Ray's or envpool's do): independent of what ran before in this suite."""
    script = textwrap.dedent(f"""
        import os, signal, sys, threading, time
        sys.path.insert(0, {ROOT!r})
        from rlchain.algos.base.safety import StopSignals
        # what the process started with: default_int_handler, or SIG_IGN under a launcher that ignores SIGINT
        before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
        stop = threading.Event()
        for _ in range(4):
            threading.Thread(target=lambda: [time.sleep(0.0005) for _ in iter(stop.is_set, True)],
                             daemon=True).start()
        with StopSignals() as signals:
            os.kill(os.getpid(), signal.SIGTERM)
            deadline = time.monotonic() + 10
            while signals.requested is None and time.monotonic() < deadline:
                time.sleep(0.001)
            print("first", signals.requested, flush=True)
            try:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(10)
                print("second ignored")
            except KeyboardInterrupt as exc:
                print("second", exc)
        stop.set()
        print("restored", signal.getsignal(signal.SIGINT) is before[0], signal.getsignal(signal.SIGTERM) is before[1])
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    lines = [line for line in out.stdout.splitlines() if line and not line.endswith("(send it again to exit at once)")]
    assert lines == ["first SIGTERM", "second second SIGINT", "restored True True"], out.stdout


def test_sigkill_during_checkpoint_write_keeps_previous(tmp_path):
    path = tmp_path / "x.pth"
    script = textwrap.dedent(f"""
        import sys, time, torch
        sys.path.insert(0, {ROOT!r})
        from rlchain.runs import checkpoint as ckpt
        ckpt.save_atomic({{"format": ckpt.FORMAT, "value": 1}}, {str(path)!r})
        real_save = torch.save
        def slow_save(obj, fh):
            fh.write(b"half a checkpoint")
            fh.flush()
            print("writing", flush=True)
            time.sleep(60)
        torch.save = slow_save
        ckpt.save_atomic({{"format": ckpt.FORMAT, "value": 2}}, {str(path)!r})
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "writing"
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        proc.kill()
    assert ckpt.load(str(path))["value"] == 1
    assert os.listdir(tmp_path) != ["x.pth"]  # the temp file is left aside, never in place of x.pth


def test_checkpoint_records_version_and_config(tmp_path):
    result = cartpole(tmp_path, epochs=1).train()
    state = ckpt.load(os.path.join(result.run_dir, "nn", "last_cartpole.pth"))
    from rlchain import __version__
    assert state["version"] == __version__
    assert state["config"]["params"]["config"]["env_name"] == "CartPole-v1"


def test_nan_reward_stops_with_env_and_epoch(tmp_path):
    runner = cartpole(tmp_path, "params.config.env_name=NanRewardCartPole-test")
    with pytest.raises(DivergenceError, match=r"epoch 1: the env returned a non-finite reward \(env \d+, step 9"):
        runner.train()
    for path in glob.glob(str(tmp_path / "runs" / "*" / "nn" / "*.pth")):
        assert all(torch.isfinite(v).all() for v in ckpt.load(path)["model"].values() if v.is_floating_point())


def test_absurd_learning_rate_stops(tmp_path):
    runner = cartpole(tmp_path, "params.config.learning_rate=1e30", "params.config.lr_schedule=None",
                      "params.config.truncate_grads=false", epochs=20)
    with pytest.raises(DivergenceError, match=r"training diverged at epoch \d+: .*(loss|norm|parameter)"):
        runner.train()


def test_absurd_learning_rate_rolls_back(tmp_path, capsys):
    runner = cartpole(tmp_path, "params.config.learning_rate=1e30", "params.config.lr_schedule=None",
                      "params.config.truncate_grads=false", "params.config.divergence.action=rollback",
                      "params.config.divergence.max_rollbacks=3", "params.config.divergence.lr_factor=1e-33",
                      epochs=4)
    result = runner.train()
    assert result.epoch == 4
    assert "rolled back to epoch" in capsys.readouterr().out


def test_env_that_raises_names_env_and_saves(tmp_path):
    runner = cartpole(tmp_path, "params.config.env_name=RaisingCartPole-test", "params.config.num_actors=4",
                      "params.config.minibatch_size=64")
    with pytest.raises(EnvError, match=r"env step failed at epoch 1: EnvIndexError: env 0 step raised "
                                       r"ValueError: simulator exploded"):
        runner.train()


class _RaisesInEpochTwo(Callback):
    def on_env_step(self, ctx, result, done_indices, rows):
        if ctx.state.epoch >= 1:
            raise KeyError("my callback's own bug")


def test_callback_that_raises_is_the_users_error_and_saves(tmp_path, caplog):
    runner = cartpole(tmp_path)
    with caplog.at_level(logging.ERROR), pytest.raises(KeyError, match="my callback's own bug"):
        runner.train(callbacks=[_RaisesInEpochTwo()])  # the callback's own exception, not "env step failed"
    assert "callback _RaisesInEpochTwo failed in on_env_step: KeyError" in caplog.text
    assert "last completed epoch 1 saved to" in caplog.text
    last = glob.glob(str(tmp_path / "runs" / "*" / "nn" / "last_*.pth"))
    assert len(last) == 1 and ckpt.load(last[0])["epoch"] == 1


@pytest.mark.timeout(120)
def test_async_env_that_raises_does_not_hang(tmp_path):
    runner = cartpole(tmp_path, "params.config.env_name=RaisingCartPole-test", "params.config.num_actors=2",
                      "params.config.minibatch_size=32", "params.config.vecenv_type=async")
    with pytest.raises(EnvError, match=r"env \d step raised ValueError: simulator exploded"):
        runner.train()


def test_wrong_observation_shape_is_clear(tmp_path):
    runner = cartpole(tmp_path, "params.config.env_name=WrongShapeCartPole-test")
    with pytest.raises(EnvError, match=r"env reset failed"):
        runner.train()


def test_unwritable_run_folder_fails_before_training(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    out = run_cli(["--train", "--file", CARTPOLE, f"params.config.train_dir={blocker}/runs"], tmp_path)
    assert out.returncode == 2
    assert "cannot create run folder" in out.stderr and "epoch" not in out.stdout


def test_failed_checkpoint_write_is_reported_and_training_goes_on(tmp_path, monkeypatch, capsys):
    real = ckpt.save_atomic
    calls = []

    def flaky(state, path):
        calls.append(path)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        real(state, path)

    monkeypatch.setattr(ckpt, "save_atomic", flaky)
    result = cartpole(tmp_path, epochs=3).train()
    assert result.epoch == 3
    assert "No space left on device" in capsys.readouterr().out
    assert ckpt.load(os.path.join(result.run_dir, "nn", "last_cartpole.pth"))["epoch"] == 3


def test_failed_log_write_is_reported_and_training_goes_on(tmp_path, monkeypatch, capsys):
    from torch.utils.tensorboard import SummaryWriter

    def broken(self, *args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(SummaryWriter, "add_scalar", broken)
    result = cartpole(tmp_path, epochs=2).train()
    assert result.epoch == 2
    out = capsys.readouterr().out
    assert out.count("TensorBoard log write failed") == 1
    assert ckpt.load(os.path.join(result.run_dir, "nn", "last_cartpole.pth"))["epoch"] == 2
