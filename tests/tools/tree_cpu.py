"""Run a command and print the CPU seconds of its whole process tree: the command, its children and every
process they started that outlived its parent (Ray's raylet, GCS and worker processes, which the test process
never waits for, so neither ``time`` nor ``RLCHAIN_TEST_TIMES`` counts them).

    python tests/tools/tree_cpu.py -- python -m pytest -q tests/smoke/test_ray_env.py

This process makes itself the subreaper of the tree (Linux ``PR_SET_CHILD_SUBREAPER``): an orphaned descendant
is handed to it, and it waits for every one, so their CPU time lands in its own children's usage. It waits at
most ``--linger`` seconds after the command for what is left over, then stops them (named on stderr).

That usage misses the processes whose parent ignores SIGCHLD: the kernel reaps those at once and drops their CPU
time. Ray's raylet does (its ``SigIgn`` mask holds SIGCHLD), so every Ray worker that ends while Ray runs (an actor
killed or replaced, a Tune trial's actor) is lost to it. So it also reads every process of the tree from ``/proc``
every 0.1 s and prints the sum of their last readings, by process name (``ray::EnvWorker``, ``raylet``, ...): that
figure misses only a process's last 0.1 s, and the processes that live less.
"""

import argparse
import collections
import ctypes
import os
import resource
import signal
import subprocess
import sys
import time

PR_SET_CHILD_SUBREAPER = 36


def _reap_all(deadline: float) -> list[int]:
    """Wait for every descendant handed to this process until none is left or the deadline passes; the pids
    still alive then."""
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return []
        if pid == 0:
            if time.monotonic() > deadline:
                return [int(p) for p in os.listdir("/proc") if p.isdigit() and _ppid(int(p)) == os.getpid()]
            time.sleep(0.1)


def _ppid(pid: int) -> int:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return int(fh.read().rsplit(")", 1)[1].split()[1])
    except (OSError, IndexError, ValueError):
        return -1


def _stats() -> dict[int, tuple[int, str, float, int]]:
    """pid -> (parent pid, name, CPU seconds so far, start time) of every process /proc shows."""
    tick = os.sysconf("SC_CLK_TCK")
    out = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as fh:
                data = fh.read()
        except OSError:
            continue
        head, _, tail = data.rpartition(")")
        fields = tail.split()
        out[int(entry)] = (int(fields[1]), head.partition("(")[2], (int(fields[11]) + int(fields[12])) / tick,
                           int(fields[19]))
    return out


def _sample(seen: dict[tuple[int, int], tuple[str, float]]) -> None:
    """Record the CPU seconds of every descendant of this process (keyed by pid and start time)."""
    stats = _stats()
    children = collections.defaultdict(list)
    for pid, (ppid, *_) in stats.items():
        children[ppid].append(pid)
    stack = [os.getpid()]
    while stack:
        for pid in children.get(stack.pop(), ()):
            _, name, cpu, start = stats[pid]
            seen[(pid, start)] = (name, cpu)
            stack.append(pid)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--linger", type=float, default=60.0, help="seconds to wait for leftovers after the command")
    parser.add_argument("command", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("no command given")
    if ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) != 0:
        print("tree_cpu: prctl(PR_SET_CHILD_SUBREAPER) failed; only waited-for children are counted", file=sys.stderr)
    start = time.perf_counter()
    seen: dict[tuple[int, int], tuple[str, float]] = {}
    proc = subprocess.Popen(command)
    while proc.poll() is None:
        _sample(seen)
        time.sleep(0.1)
    status = proc.returncode
    wall = time.perf_counter() - start
    _sample(seen)
    left = _reap_all(time.monotonic() + args.linger)
    for pid in left:
        print(f"tree_cpu: pid {pid} still alive {args.linger:.0f} s after the command; killed", file=sys.stderr)
        os.kill(pid, signal.SIGKILL)
    _reap_all(time.monotonic() + 5.0)
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"tree_cpu: exit {status}, wall {wall:.1f} s, CPU {usage.ru_utime + usage.ru_stime:.1f} s "
          f"(user {usage.ru_utime:.1f}, system {usage.ru_stime:.1f}): {' '.join(command)}", file=sys.stderr)
    names: collections.Counter = collections.Counter()
    for name, cpu in seen.values():
        names[name] += cpu
    top = ", ".join(f"{name} {cpu:.1f}" for name, cpu in names.most_common(8))
    print(f"tree_cpu: sampled from /proc every 0.1 s: CPU {sum(names.values()):.1f} s in {len(seen)} processes "
          f"({top})", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
