"""Jupyter kernels for tests/smoke/test_notebooks.py, started as forks of a preloaded Python.

jupyter_client starts a kernel as ``python -m ipykernel_launcher -f CONNECTION_FILE`` (subprocess.Popen, in
jupyter_client.provisioning.local_provisioner.launch_kernel), which imports ipykernel, then the notebook's cells
import torch and rlchain: about 5 s of CPU a notebook before its first training step. ``launch_kernel`` here runs
that same command in a child of tests/smoke/forkserver.py (torch, rlchain and ipykernel already imported), and gives
jupyter_client a process handle for it: the kernel is the same ipykernel, on the same connection file, environment
and working directory, interrupted and killed by signals to its process group (its own session) as before.
``RLCHAIN_TESTS_FRESH=1`` starts fresh kernels instead.
"""

from __future__ import annotations

import contextlib
import os
import signal
import tempfile
import time

from tests.smoke.forkserver_client import ForkServer


class ForkedKernel:
    """What jupyter_client's LocalProvisioner uses of the Popen of its kernel, for a fork server's child."""

    stdin = stdout = stderr = None

    def __init__(self, server: ForkServer, pid: int):
        self.server, self.pid, self.returncode = server, pid, None

    def poll(self) -> int | None:
        if self.returncode is None:
            self.returncode = self.server.finished(timeout=0)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int | None:
        if self.returncode is None:
            self.returncode = self.server.finished(timeout)
        return self.returncode

    def send_signal(self, signum: int) -> None:
        if self.returncode is None:
            os.kill(self.pid, signum)

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


def forked_launcher(server: ForkServer):
    """A stand-in for jupyter_client's ``launch_kernel(cmd, **kwargs)`` that starts the kernel in ``server``
    (tests/smoke/forkserver.py, one kernel at a time)."""

    def launch_kernel(cmd: list[str], stdin=None, stdout=None, stderr=None, env=None, independent=False, cwd=None,
                      **kwargs) -> ForkedKernel:
        logs = tempfile.mkdtemp(prefix="rlchain_kernel_")  # the kernel's own streams (its output goes over zmq)
        pid = server.start(list(cmd), str(cwd or os.getcwd()), dict(env if env is not None else os.environ),
                           os.path.join(logs, "stdout"), os.path.join(logs, "stderr"))
        # the child leads a session of its own once it has called setsid: jupyter_client reads the kernel's process
        # group right after this returns and signals that group (a SIGKILL to the server's group would be ours)
        deadline = time.monotonic() + 30
        while os.getpgid(pid) != pid:
            if time.monotonic() > deadline:
                raise RuntimeError(f"the forked kernel {pid} did not start a session of its own")
            time.sleep(0.005)
        return ForkedKernel(server, pid)

    return launch_kernel


@contextlib.contextmanager
def preloaded_server(env: dict[str, str]):
    """A fork server that has imported torch, rlchain and ipykernel's kernel app, started with ``env`` (the
    kernels' environment: what a module reads from it at import, as MPLBACKEND, is the kernels')."""
    server = ForkServer(env, preload=("ipykernel.kernelapp",))
    try:
        yield server
    finally:
        server.close()
