"""A fork server for the docs' commands: one Python that has imported torch and rlchain's entry points forks a child
per ``python ...`` / ``rlchain ...`` command, so each command pays for its own work, not for importing torch and
rlchain again (about 4 s of CPU each on a 2-core machine, most of a one-epoch command).

The child is the command as a fresh ``python`` would run it: its own process and session, working directory,
environment, ``sys.argv``, ``sys.path[0]``, standard streams (files) and exit status; atexit handlers,
non-daemon threads and the finalizers of unreachable objects end as at a normal interpreter exit (the modules are not
torn down: see exit_child). What differs: torch (with torch._dynamo, which torch
imports at a process's first optimizer, and its TensorBoard writer), numpy, gymnasium's classic-control envs and
rlchain (its algorithms, networks, example envs and SB3-style classes, which a training run imports) are already
imported (from this tree) when the command starts. Imported, not registered: rlchain registers its built-ins at a
child's first lookup, as in a fresh process, so a user's module that registers a built-in's name first still wins.
``RLCHAIN_DOCS_FRESH=1`` makes tests/smoke/test_docs_commands.py start every command fresh instead.
``forkserver.py --installed`` imports the rlchain installed in the interpreter it runs on instead of this tree's
(tests/smoke/test_wheel_install.py: the wheel in a fresh venv). tests/smoke/forkserver_client.py is the caller's side.

Protocol: one JSON request a line on stdin ``{"argv", "cwd", "env", "stdout", "stderr"}`` and optionally
``"prelude": "module:function"``, called in the child before the command (the docs tests' caps on a python block's
training, tests/smoke/docs_caps.py); the server answers
``{"pid": N}`` when the child runs and ``{"status": S}`` when it has ended (S < 0: killed by signal -S). The
caller kills a child that runs too long (``os.killpg(pid, SIGKILL)``: the child leads its own session).
With ``"detach": true`` the command runs in a grandchild that the server does not wait for (the init process reaps
it): the answer is its ``{"pid": N}`` alone, and the server takes the next request while it runs (a server or
watcher that runs until stopped, beside the commands after it); the caller sees it run in /proc and stops it.
"""

from __future__ import annotations

import gc
import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
INSTALLED = "--installed" in sys.argv[1:]
if INSTALLED:  # the rlchain installed in this interpreter (the wheel test's venv): nothing of the clone on the path
    del sys.path[0]
else:
    sys.path[0] = ROOT  # this tree's rlchain, as the docs' working directories link it

import gymnasium.envs.classic_control  # noqa: E402,F401  (CartPole, Pendulum: most pages' envs)
import numpy  # noqa: E402,F401  (preloaded for the children)
import torch  # noqa: E402,F401
import torch._dynamo  # noqa: E402,F401  (torch imports it at a process's first optimizer: about 2 s of CPU)
import torch.utils.tensorboard  # noqa: E402,F401  (every training run's summary writer)

import rlchain.algos  # noqa: E402,F401  (the algorithm registry a config's algo.name is looked up in)
import rlchain.builtins  # noqa: E402,F401  (every built-in algorithm, network and env; imported, not registered)
import rlchain.cli  # noqa: E402,F401
import rlchain.console  # noqa: E402,F401
import rlchain.envs.examples  # noqa: E402,F401  (the example envs the shipped configs register)
import rlchain.runner  # noqa: E402,F401
import rlchain.sb3  # noqa: E402,F401  (the SB3-style classes of the README and docs/sb3.md)

# --preload MODULE (repeatable): more modules to import once, where installed (the docs pages' envpool: three MuJoCo
# commands, about 2 s of CPU each to import it); a module that is not installed is left to the commands, which
# import it, or fail, as a fresh process would
for _at, _flag in enumerate(sys.argv[:-1]):
    if _flag == "--preload":
        try:
            __import__(sys.argv[_at + 1])
        except ImportError:
            pass


def python_argv(argv: list[str]) -> tuple[str, str, list[str]] | None:
    """(kind, target, sys.argv) for ``python [-u] SCRIPT|-m MOD|-c CODE args...``, the ``rlchain`` console script or
    the ``torchrun`` launcher; None for anything else (the caller runs it through bash)."""
    head, rest = os.path.basename(argv[0]), argv[1:]
    if head == "rlchain":
        return "console", "", [argv[0], *rest]
    if head == "torchrun":
        return "torchrun", "", [argv[0], *rest]
    if not head.startswith("python") or not rest:
        return None
    if rest[0] == "-u":  # unbuffered standard streams (torchrun starts its workers so): see unbuffered()
        rest = rest[1:]
        if not rest:
            return None
    if rest[0] == "-m" and len(rest) > 1:
        return "module", rest[1], [rest[1], *rest[2:]]
    if rest[0] == "-c" and len(rest) > 1:
        return "code", rest[1], ["-c", *rest[2:]]
    if rest[0].startswith("-"):
        return None
    return "script", rest[0], rest


def run_command(kind: str, target: str, argv: list[str]) -> int:
    """Run the command in this (forked) process as ``python`` would; returns its exit status."""
    import runpy
    import traceback

    sys.argv = argv
    sys.path[0] = {"script": os.path.dirname(os.path.abspath(target)), "console": os.path.dirname(argv[0]),
                   "torchrun": os.path.dirname(argv[0])}.get(kind, os.getcwd())
    try:
        if kind == "console":
            return rlchain.console.main() or 0
        if kind == "torchrun" or (kind == "module" and target == "torch.distributed.run"):
            fork_torchrun_workers()
        if kind == "torchrun":
            import torch.distributed.run

            torch.distributed.run.main(argv[1:])
            return 0
        if kind == "module":
            runpy.run_module(target, run_name="__main__", alter_sys=True)
        elif kind == "code":
            exec(compile(target, "<string>", "exec"), {"__name__": "__main__", "__builtins__": __builtins__})
        else:
            runpy.run_path(target, run_name="__main__")
        return 0
    except SystemExit as stop:
        code = stop.code
        if code is None:
            return 0
        if isinstance(code, int):
            return code
        print(code, file=sys.stderr)
        return 1
    except BaseException:  # noqa: BLE001  (the interpreter prints the traceback and exits 1: so does the child)
        traceback.print_exc()
        return 1


def fork_torchrun_workers() -> None:
    """Make the torchrun launcher running in this (forked) process start its workers as forks of it, each running
    its ``python -u SCRIPT|-m MOD args`` as run_command does, instead of as new interpreters that import torch and
    rlchain again (about 4 s of CPU a worker). The launcher is torchrun's own (its rendezvous, environment
    variables, monitoring, signals and exit statuses); what differs is the worker's start, as for any command here."""
    import inspect
    import subprocess

    from torch.distributed.elastic.multiprocessing.subprocess_handler import subprocess_handler

    fields = list(inspect.signature(subprocess.Popen._execute_child).parameters)[1:]

    class ForkedPopen(subprocess.Popen):
        """A Popen whose child is a fork of this process running a python command (python_argv), not an exec."""

        def _execute_child(self, *args):
            call = dict(zip(fields, args))
            parsed = python_argv(list(call["args"]))
            for stream in (sys.stdout, sys.stderr):  # what the launcher wrote is not the worker's to write again
                stream.flush()
            pid = os.fork()
            if pid == 0:
                start_worker(call)
                exit_child(run_command(*parsed) if parsed else 127)
            self.pid = pid
            self._child_created = True
            self._close_pipe_fds(call["p2cread"], call["p2cwrite"], call["c2pread"], call["c2pwrite"],
                                 call["errread"], call["errwrite"])

    subprocess_handler.Popen = ForkedPopen


def start_worker(call: dict) -> None:
    """In a worker forked by ForkedPopen: what a new process started by Popen(``call``) would have: its session,
    standard streams, working directory and environment, default signal handlers (the launcher's are torchrun's),
    no exit handlers of the launcher's, unbuffered output (``python -u``)."""
    import atexit
    import signal

    if call["start_new_session"]:
        os.setsid()
    for fd, target in ((call["p2cread"], 0), (call["c2pwrite"], 1), (call["errwrite"], 2)):
        if fd != -1 and fd != target:
            os.dup2(fd, target)
    if call["cwd"] is not None:
        os.chdir(call["cwd"])
    if call["env"] is not None:
        os.environ.clear()
        os.environ.update(call["env"])
    signal.signal(signal.SIGINT, signal.default_int_handler)
    for sig in (signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT):
        signal.signal(sig, signal.SIG_DFL)
    atexit._clear()
    for stream in (sys.stdout, sys.stderr):
        stream.reconfigure(line_buffering=True, write_through=True)


def run_prelude(target: str) -> None:
    """Call ``module:function`` (imported from this tree) in the child, before its command."""
    import importlib

    module, _, function = target.partition(":")
    getattr(importlib.import_module(module), function)()


def exit_child(status: int) -> None:
    """End a forked child as the interpreter ends: non-daemon threads joined, atexit handlers run, finalizers of
    unreachable objects run, standard streams flushed; then ``os._exit``. What it skips is the interpreter's
    teardown of every module, which in a forked child writes to (so copies) every memory page that the server's
    imports filled: about 1.4 s of CPU a command, more than a one-epoch command's own work."""
    import atexit
    import threading

    try:
        threading._shutdown()  # what the interpreter does first at exit: wait for non-daemon threads
        atexit._run_exitfuncs()
        gc.collect()
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
    finally:
        os._exit(status)


def run_child(request: dict, parsed: tuple[str, str, list[str]] | None) -> None:
    """In a forked child: become the requested command (its session, folder, environment, standard streams), run
    it and exit with its status; never returns."""
    os.setsid()
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update(request["env"])
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    for fd, path in ((1, request["stdout"]), (2, request["stderr"])):  # files, or a pseudo-terminal's
        # slave: O_NOCTTY, so it does not become the new session's controlling terminal, which the
        # kernel would hang up (its unread output dropped) when the child exits
        os.dup2(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOCTTY, 0o644), fd)
    sys.stdin = open(0, closefd=False)
    if parsed and request.get("prelude"):
        run_prelude(request["prelude"])
    exit_child(run_command(*parsed) if parsed else 127)


def start_detached(request: dict, parsed: tuple[str, str, list[str]] | None) -> int:
    """Run the command in a grandchild, orphaned at once so that the init process, not this server, reaps it;
    returns its pid."""
    read, write = os.pipe()
    middle = os.fork()
    if middle == 0:
        os.close(read)
        pid = os.fork()
        if pid == 0:
            os.close(write)
            run_child(request, parsed)
        os.write(write, str(pid).encode())
        os._exit(0)
    os.close(write)
    with os.fdopen(read) as fh:
        pid = int(fh.read())
    os.waitpid(middle, 0)
    return pid


def serve() -> None:
    """Answer requests until stdin closes (returns None); a child runs one command and exits (exit_child)."""
    gc.freeze()  # the imported objects: a collection in a child skips them instead of copying their pages
    for line in sys.stdin:
        request = json.loads(line)
        parsed = python_argv(request["argv"])
        if request.get("detach"):
            print(json.dumps({"pid": start_detached(request, parsed)}), flush=True)
            continue
        pid = os.fork()
        if pid == 0:
            run_child(request, parsed)
        print(json.dumps({"pid": pid}), flush=True)
        _, status, usage = os.wait4(pid, 0)
        cpu = usage.ru_utime + usage.ru_stime  # the child and what it waited for
        print(json.dumps({"status": os.waitstatus_to_exitcode(status), "cpu": round(cpu, 2)}), flush=True)
    return None


if __name__ == "__main__":
    serve()
