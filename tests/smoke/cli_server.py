"""``python runner.py ...`` for the smoke tests, run in a child of one fork server per test process.

tests/smoke/forkserver.py (started once, at the first call) has already imported torch, torch._dynamo and
rlchain, so each command pays for its own work, not about 3 s of CPU for the imports. The child is otherwise the
command as a fresh ``python`` runs it: its own process, working directory, environment, ``sys.argv``, standard
streams and exit status (forkserver.py says what is and is not the same). ``RLCHAIN_TESTS_FRESH=1`` runs every
command in a fresh process instead.
"""

from __future__ import annotations

import atexit
import contextlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading

from tests.conftest import ROOT

_server: subprocess.Popen | None = None
_lock = threading.Lock()


def _start() -> subprocess.Popen:
    global _server
    if _server is None or _server.poll() is not None:
        env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
        _server = subprocess.Popen([sys.executable, os.path.join(ROOT, "tests", "smoke", "forkserver.py")],
                                   cwd=ROOT, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        atexit.register(_stop, _server)
    return _server


def _stop(server: subprocess.Popen) -> None:
    with contextlib.suppress(OSError):
        server.stdin.close()
    try:
        server.wait(timeout=30)
    except subprocess.TimeoutExpired:
        server.kill()


def _kill_session(pid: int) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pid, signal.SIGKILL)


def run_python(argv: list[str], cwd, env: dict[str, str], timeout: float) -> subprocess.CompletedProcess:
    """``argv`` (``[sys.executable, SCRIPT, args...]``) as ``subprocess.run(..., capture_output=True, text=True,
    timeout=timeout)`` returns it; a command that runs past ``timeout`` raises ``subprocess.TimeoutExpired``."""
    if os.environ.get("RLCHAIN_TESTS_FRESH") == "1":
        return subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    with start_python(argv, cwd, env) as command:
        return command.wait(timeout)


class Started:
    """A command :func:`start_python` started: its process id (the leader of its own session), the file its
    standard output goes to, and :meth:`wait` for its end."""

    def __init__(self, argv: list[str], pid: int, stdout: str, stderr: str, status) -> None:
        self.argv, self.pid, self.stdout, self.stderr = argv, pid, stdout, stderr
        self._status = status  # blocks until the command has ended; returns its exit status
        self.returncode: int | None = None

    def output(self) -> str:
        """What the command has written to its standard output so far ("" where it goes to a terminal)."""
        if not os.path.isfile(self.stdout):
            return ""
        with open(self.stdout, encoding="utf-8", errors="replace") as fh:
            return fh.read()

    def wait(self, timeout: float) -> subprocess.CompletedProcess:
        """The ended command as ``subprocess.run(..., capture_output=True, text=True)`` returns it; past ``timeout``
        its session is killed and ``subprocess.TimeoutExpired`` raised."""
        expired = []
        timer = threading.Timer(timeout, lambda: expired.append(True) or _kill_session(self.pid))
        timer.start()
        try:
            self.returncode = self._status()
        finally:
            timer.cancel()
        with open(self.stderr, encoding="utf-8", errors="replace") as fh:
            stdout, stderr = self.output(), fh.read()
        if expired:
            raise subprocess.TimeoutExpired(self.argv, timeout, stdout, stderr)
        return subprocess.CompletedProcess(self.argv, self.returncode, stdout, stderr)


@contextlib.contextmanager
def start_python(argv: list[str], cwd, env: dict[str, str], stdout: str | None = None):
    """Start ``argv`` (``[sys.executable, SCRIPT|-m MODULE, args...]``) in a child of the fork server and yield it
    running (:class:`Started`): a test that reads its output as it comes or signals it (``os.kill(pid, ...)``).
    ``stdout``: a path its standard output goes to instead of a file of its own (a pseudo-terminal's, say). A
    command not waited for by the end of the block is killed. ``RLCHAIN_TESTS_FRESH=1``: a fresh process."""
    global _server
    with _lock, tempfile.TemporaryDirectory(prefix="rlchain_cli_") as folder:
        out, err = stdout or os.path.join(folder, "stdout"), os.path.join(folder, "stderr")
        if os.environ.get("RLCHAIN_TESTS_FRESH") == "1":
            with open(out, "wb") as fh_out, open(err, "wb") as fh_err:
                proc = subprocess.Popen(argv, cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=fh_out,
                                        stderr=fh_err, start_new_session=True)
            command = Started(argv, proc.pid, out, err, proc.wait)
            try:
                yield command
            finally:
                if command.returncode is None:
                    _kill_session(proc.pid)
                    proc.wait()
            return
        server = _start()
        request = {"argv": ["python", *argv[1:]], "cwd": str(cwd), "env": env, "stdout": out, "stderr": err}
        server.stdin.write(json.dumps(request) + "\n")
        server.stdin.flush()
        pid = json.loads(server.stdout.readline())["pid"]
        command = Started(argv, pid, out, err, lambda: json.loads(server.stdout.readline())["status"])
        try:
            yield command
        finally:
            if command.returncode is None:  # not waited for, or the test was stopped (its timeout, Ctrl-C): the
                _kill_session(pid)  # next command gets a new server
                server.kill()
                _server = None
