"""The caller's side of tests/smoke/forkserver.py: start the server once, send it commands, read what they did.

Used by the docs pages' commands (test_docs_commands.py, on the test venv with this tree's rlchain) and by the
installed wheel's commands (test_wheel_install.py, on the fresh venv with ``--installed``: the wheel's rlchain).
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import subprocess
import sys
import threading

SERVER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "forkserver.py")


class ForkServer:
    """tests/smoke/forkserver.py, started once: runs plain python / rlchain commands in a child forked from a
    Python that has already imported torch and rlchain (see that file for what is and is not the same).

    ``python``: the interpreter the server runs on (this one by default); ``installed``: it imports the rlchain
    installed in that interpreter, not this tree's; ``stop_grace``: the seconds a command stopped with SIGINT
    (``stop_after``) has to end before it is killed; ``preload``: more modules the server imports once, where
    installed."""

    def __init__(self, env: dict[str, str], stop_grace: float = 5, python: str = sys.executable,
                 installed: bool = False, cwd: str | None = None, preload: tuple[str, ...] = ()):
        argv = [python, SERVER, *(["--installed"] if installed else []),
                *(arg for module in preload for arg in ("--preload", module))]
        self.proc = subprocess.Popen(argv, cwd=cwd or os.path.dirname(os.path.dirname(os.path.dirname(SERVER))),
                                     env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.stop_grace = stop_grace
        self.last_cpu = 0.0  # CPU seconds of the last command (it and its children)

    def run(self, argv: list[str], ws: str, env: dict, timeout: float, stop_after: float | None = None,
            prelude: str | None = None) -> tuple[int | None, str, str]:
        """(exit status, stdout, stderr) of ``argv`` in ``ws``; the child is killed after ``timeout`` seconds
        (status -9). With ``stop_after``: a child still running then gets SIGINT (as a user's Ctrl-C) and the status
        is None. ``prelude``: ``module:function`` the child calls before the command (forkserver.py)."""
        out, err = os.path.join(ws, "_stdout.txt"), os.path.join(ws, "_stderr.txt")
        pid = self.start(argv, ws, env, out, err, prelude)
        stopped = False
        if stop_after is not None and not select.select([self.proc.stdout], [], [], stop_after)[0]:
            stopped = True
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(pid, signal.SIGINT)
            timeout = self.stop_grace
        timer = threading.Timer(timeout, _kill_session, (pid,))
        timer.start()
        try:
            answer = json.loads(self.proc.stdout.readline())
        finally:
            timer.cancel()
        self.last_cpu = answer.get("cpu", 0.0)
        status = None if stopped else answer["status"]
        texts = []
        for path in (out, err):
            with open(path, encoding="utf-8", errors="replace") as fh:
                texts.append(fh.read())
            os.remove(path)
        return status, texts[0], texts[1]

    def start(self, argv: list[str], cwd: str, env: dict, stdout: str, stderr: str,
              prelude: str | None = None) -> int:
        """Start ``argv`` in a child (its standard streams into the files ``stdout`` and ``stderr``); its pid. The
        server runs one command at a time: ``finished`` (or ``run``) reads how this one ended."""
        request = {"argv": argv, "cwd": cwd, "env": env, "stdout": stdout, "stderr": stderr, "prelude": prelude}
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        return json.loads(self.proc.stdout.readline())["pid"]

    def start_detached(self, argv: list[str], cwd: str, env: dict, stdout: str, stderr: str) -> int:
        """Start ``argv`` in a grandchild the server does not wait for (forkserver.py, ``"detach"``); its pid. The
        server takes the next command at once; the caller watches this one in /proc and stops it (it leads its own
        session)."""
        request = {"argv": argv, "cwd": cwd, "env": env, "stdout": stdout, "stderr": stderr, "detach": True}
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        return json.loads(self.proc.stdout.readline())["pid"]

    def finished(self, timeout: float | None = None) -> int | None:
        """The exit status of the command ``start`` started (negative: killed by that signal), once it has ended;
        None if it is still running after ``timeout`` seconds (None: wait for it)."""
        if timeout is not None and not select.select([self.proc.stdout], [], [], timeout)[0]:
            return None
        answer = json.loads(self.proc.stdout.readline())
        self.last_cpu = answer.get("cpu", 0.0)
        return answer["status"]

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait(timeout=30)


def _kill_session(pid: int) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pid, signal.SIGKILL)
