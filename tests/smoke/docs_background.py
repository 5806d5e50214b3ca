"""The docs' commands that run until stopped (``<!-- test: run timeout=N -->``: a server, a watcher), in the background.

Each must still be running ``N`` seconds after it started, with no traceback in its output, as when the page waited
for it; but the page's later blocks and the pages after it run meanwhile, instead of the test sleeping ``N`` seconds
(TensorBoard and the checkpoint watcher: about 8 of their 10 s idle). A python / rlchain command runs detached from
the docs' fork server (tests/smoke/forkserver.py, ``"detach"``), anything else (``tensorboard ...``) through bash.
tests/smoke/test_docs_commands.py starts them (:func:`start`) and its last test checks them (:func:`finish`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

POLL = 0.1  # seconds between two looks at a background command


def running(pid: int) -> bool:
    """Whether process ``pid`` runs (one that ended and is not yet reaped, a zombie, does not)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="utf-8") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def cpu_seconds(pid: int) -> float:
    """CPU seconds process ``pid`` and the children it waited for have used so far (0.0 once it is gone)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="utf-8") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        return sum(int(value) for value in fields[11:15]) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return 0.0


@dataclass
class Background:
    """One command running in the background: where the page shows it, how it runs, and once :meth:`watch` is done,
    whether it was still running ``seconds`` after its start and what it wrote."""

    where: str
    shown: str
    seconds: float
    pid: int
    alive: Callable[[], bool]
    reap: Callable[[], object]
    files: tuple[str, str]
    stop_grace: float
    started: float = field(default_factory=time.monotonic)
    ran_on: bool | None = None
    output: str = ""
    cpu: float = 0.0
    wall: float = 0.0
    thread: threading.Thread | None = None

    def watch(self) -> None:
        """Until ``seconds`` after the start: look whether it still runs; then stop it as a user's Ctrl-C does
        (SIGINT to its session; SIGKILL after ``stop_grace`` seconds) and keep its output."""
        deadline = self.started + self.seconds
        while self.alive() and time.monotonic() < deadline:
            time.sleep(POLL)
        self.ran_on = self.alive()
        self.cpu = cpu_seconds(self.pid)
        self.wall = time.monotonic() - self.started
        if self.ran_on:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(self.pid, signal.SIGINT)
            end = time.monotonic() + self.stop_grace
            while self.alive() and time.monotonic() < end:
                time.sleep(POLL)
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(self.pid, signal.SIGKILL)
        self.reap()
        texts = []
        for path in self.files:
            with open(path, encoding="utf-8", errors="replace") as fh:
                texts.append(fh.read())
        self.output = "".join(texts)


def start(where: str, shown: str, seconds: float, ws: str, env: dict, stop_grace: float, server=None,
          direct: list[str] | None = None) -> Background:
    """Start ``shown`` in ``ws``: ``direct`` (its argv, its environment already in ``env``) detached from the fork
    ``server`` where both are given, else ``bash -c shown``; a thread watches it (:meth:`Background.watch`)."""
    tag = where.replace("/", "_").replace(":", "_")
    files = (os.path.join(ws, f"_background_{tag}_stdout.txt"), os.path.join(ws, f"_background_{tag}_stderr.txt"))
    if server is not None and direct is not None:
        pid = server.start_detached(direct, ws, env, *files)
        job = Background(where, shown, seconds, pid, lambda: running(pid), lambda: None, files, stop_grace)
    else:
        with open(files[0], "wb") as out, open(files[1], "wb") as err:
            proc = subprocess.Popen(["bash", "-c", shown], cwd=ws, env=env, stdout=out, stderr=err,
                                    stdin=subprocess.DEVNULL, start_new_session=True)
        job = Background(where, shown, seconds, proc.pid, lambda: proc.poll() is None, proc.wait, files, stop_grace)
    job.thread = threading.Thread(target=job.watch, name=f"docs background {where}", daemon=True)
    job.thread.start()
    return job


def finish(jobs: list[Background]) -> list[str]:
    """Wait for every job's watch to end; the problems (a job that ended before its time, or printed a traceback),
    one line each with its output's tail. Empties ``jobs``."""
    problems = []
    while jobs:
        job = jobs.pop(0)
        job.thread.join()
        if not job.ran_on or "Traceback" in job.output:
            state = "printed a traceback" if job.ran_on else f"ended within {job.wall:.1f} s"
            problems.append(f"{job.where}: `{job.shown}` should still run after {job.seconds:g} s, but it {state}:\n"
                            f"{job.output[-3000:]}")
    return problems
