"""Replay pytest-xdist's worksteal scheduler on measured test times: how long a tier takes in collection order and in
tests/learning/order.py's longest-first order, on N workers that each run one test at a time.

    RLCHAIN_TEST_TIMES=times.tsv python -m pytest -q -m slow tests     # one process: times in collection order
    python tests/tools/worksteal_order.py times.tsv                      # the two orders on 2 workers
    python tests/tools/worksteal_order.py times.tsv --workers 3 --wall   # wall seconds instead of CPU seconds

A replay, not a run: each test takes its measured seconds whatever runs beside it (two one-thread tests on two
cores), and a worker's start-up and collection count nothing. It prints each order's end and the seconds the first
idle worker waits for the last.
"""

from __future__ import annotations

import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from tests.learning.order import longest_first, share_sizes  # noqa: E402

MIN_PENDING = 2  # xdist's worksteal: a worker with fewer tests queued (its running one included) asks for more


def replay(seconds: list[float], workers: int) -> tuple[float, float]:
    """(the time the last worker ends, the time the first one ran out of tests) for tests taking ``seconds`` in
    this order: worksteal's first hand-out (contiguous shares), then each worker down to its last test steals the
    second half of the longest queue, less the two at its front (xdist 3.x)."""
    queues: list[list[int]] = []
    start = 0
    for size in share_sizes(len(seconds), workers):
        queues.append(list(range(start, start + size)))
        start += size
    clock = [0.0] * workers  # when each worker's running test (its queue's front) ends
    for k in range(workers):
        if queues[k]:
            clock[k] = seconds[queues[k][0]]
    first_idle = None
    while any(queues):
        k = min((k for k in range(workers) if queues[k]), key=lambda k: clock[k])  # the next test to end
        now = clock[k]
        queues[k].pop(0)
        if len(queues[k]) < MIN_PENDING:
            victim = max(range(workers), key=lambda j: len(queues[j]))
            steal = min(len(queues[victim]) // 2, max(0, len(queues[victim]) - MIN_PENDING))
            if steal:
                stolen = queues[victim][-steal:]
                del queues[victim][-steal:]
                queues[k].extend(stolen)
        if queues[k]:
            clock[k] = now + seconds[queues[k][0]]
        elif first_idle is None:
            first_idle = now
    return max(clock), first_idle if first_idle is not None else max(clock)


def read_times(path: str, wall: bool) -> tuple[list[str], list[float]]:
    """Node ids and seconds (CPU, or wall) of a ``RLCHAIN_TEST_TIMES`` file, in its order (a test twice: its last)."""
    times: dict[str, float] = {}
    with open(path) as fh:
        for line in fh:
            parts = line.rstrip("\n").split("\t")
            if len(parts) != 3:
                raise SystemExit(f"{path}: a line is not 'wall<TAB>cpu<TAB>node id': {line.strip()!r}")
            times.pop(parts[2], None)
            times[parts[2]] = float(parts[0] if wall else parts[1])
    return list(times), list(times.values())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("times", help="a RLCHAIN_TEST_TIMES file (one process's run: its order is collection order)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--wall", action="store_true", help="wall seconds (default: CPU seconds)")
    args = parser.parse_args()
    names, seconds = read_times(args.times, args.wall)
    order = longest_first(seconds, args.workers)
    total = sum(seconds)
    best = total / args.workers
    print(f"{len(names)} tests, {total:.0f} s in all; {args.workers} workers: {best:.0f} s each at best")
    for label, ordered in (("collection order", seconds), ("longest first", [seconds[i] for i in order])):
        end, idle = replay(ordered, args.workers)
        print(f"{label:>16}: ends at {end:.0f} s, a worker idle from {idle:.0f} s ({end - idle:.0f} s alone)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
