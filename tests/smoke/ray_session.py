"""One small local Ray for a test module (tests/smoke/test_ray_env.py, test_tune_ray.py): started once by a
module-scoped fixture, quiet, and started again when a busy machine makes its start time out.

What a Ray start costs and where it breaks under load: ``ray.init`` starts the GCS, the raylet and their Python
agents (dashboard agent, runtime-env agent); the raylet aborts when the dashboard agent has not written its ports
within about 15 s (a fixed wait in Ray 2.60; neither ``raylet_start_wait_time_s`` nor ``agent_register_timeout_ms``
moves it), and ``ray.init`` then fails with "The current node timed out during startup", leaving the processes it
started running. On 2 cores at load 30-37 (other test runs beside it) the agent's imports alone take longer, and
about half the starts failed there; at CI's load it starts in seconds. A failed start is cleaned up here and
tried again, up to ATTEMPTS starts.
"""

from __future__ import annotations

import contextlib
import glob
import os
import signal
from collections.abc import Iterator

STARTUP_TIMEOUT = "timed out during startup"
"""What ray.init raises when the raylet did not register in time (ray/_private/node.py)."""

ATTEMPTS = 3


def _children() -> set[int]:
    """The process ids of this process's children (Ray's GCS, raylet and their helpers after a ``ray.init``)."""
    pids: set[int] = set()
    for path in glob.glob(f"/proc/{os.getpid()}/task/*/children"):
        try:
            with open(path) as fh:
                pids.update(int(pid) for pid in fh.read().split())
        except OSError:
            pass
    return pids


def _stop(pids: set[int]) -> None:
    """SIGKILL and reap what a failed ``ray.init`` left running (its processes are this process's children)."""
    for pid in pids:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)
    for pid in pids:
        with contextlib.suppress(OSError):
            os.waitpid(pid, 0)


def start(num_cpus: int) -> bool:
    """``ray.init`` a local Ray of ``num_cpus`` logical CPUs unless this process has one; True when it started one.

    No dashboard, no worker output forwarded to the test's output (the tests read errors from exceptions, not
    from the workers' logs). No runtime env either: the ``num_cpus`` idle workers the raylet starts when the driver
    connects are then the ones the first actors (env workers, Tune's trials) run in, instead of idling beside
    new ones."""
    import ray

    if ray.is_initialized():
        return False
    for attempt in range(1, ATTEMPTS + 1):
        before = _children()
        try:
            ray.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False, logging_level="WARNING")
            return True
        except Exception as exc:
            ray.shutdown()
            _stop(_children() - before)
            if attempt == ATTEMPTS or STARTUP_TIMEOUT not in str(exc):
                raise
    return False


@contextlib.contextmanager
def session(num_cpus: int) -> Iterator[None]:
    """A local Ray for the duration (see :func:`start`), shut down after unless it was already running; the
    SIGINT / SIGTERM handlers ``ray.init`` installs are the caller's again after."""
    import ray

    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    started = False
    try:
        started = start(num_cpus)
        yield
    finally:
        if started:
            ray.shutdown()
        for sig, handler in handlers.items():
            if handler is not None:
                signal.signal(sig, handler)
