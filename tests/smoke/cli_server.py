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
    with _lock, tempfile.TemporaryDirectory(prefix="rlchain_cli_") as folder:
        server = _start()
        out, err = os.path.join(folder, "stdout"), os.path.join(folder, "stderr")
        request = {"argv": ["python", *argv[1:]], "cwd": str(cwd), "env": env, "stdout": out, "stderr": err}
        server.stdin.write(json.dumps(request) + "\n")
        server.stdin.flush()
        pid = json.loads(server.stdout.readline())["pid"]
        expired = []
        timer = threading.Timer(timeout, lambda: expired.append(True) or _kill_session(pid))
        timer.start()
        try:
            status = json.loads(server.stdout.readline())["status"]
        finally:
            timer.cancel()
        with open(out, encoding="utf-8", errors="replace") as fh_out, \
                open(err, encoding="utf-8", errors="replace") as fh_err:
            stdout, stderr = fh_out.read(), fh_err.read()
    if expired:
        raise subprocess.TimeoutExpired(argv, timeout, stdout, stderr)
    return subprocess.CompletedProcess(argv, status, stdout, stderr)
