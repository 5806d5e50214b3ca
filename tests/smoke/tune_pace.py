"""A callback that makes the trials of a Ray Tune test run side by side (tests/smoke/test_tune_ray.py's PBT).

A CartPole epoch takes ~10 ms on an idle machine, and on a loaded one a trial's actor can start tens of seconds
after the other's: a 30-epoch trial then ends before the next one begins, and asynchronous PBT never sees two
trials at once and has nothing to compare. So each trial waits, at the end of its first epoch, until TOGETHER
trial processes have got there (a file per process in the search's train_dir; at most WAIT_S), and then every
epoch lasts at least PACE_S, which keeps them in step. Real trials take minutes; this gives the test's trials
that overlap, however busy the machine."""

import glob
import os
import time

from rlchain.training.events import Callback

PACE_S = 0.15
TOGETHER = 2
WAIT_S = 300.0


class Pace(Callback):
    def on_epoch_end(self, ctx, stats, episodes):
        if ctx.state.epoch == 1 and in_ray_worker():  # a trial; not a replay of the winner in the test process
            meet(ctx.params.config.train_dir, TOGETHER, WAIT_S)
        time.sleep(PACE_S)


def in_ray_worker() -> bool:
    import ray

    return ray.is_initialized() and ray.get_runtime_context().worker.mode == ray.WORKER_MODE


def meet(folder: str, count: int, seconds: float) -> int:
    """Mark this process as arrived in ``folder`` and wait until ``count`` processes have (or ``seconds``
    passed); returns how many had."""
    os.makedirs(folder, exist_ok=True)
    open(os.path.join(folder, f"pace_{os.getpid()}"), "a").close()
    deadline = time.monotonic() + seconds
    while True:
        arrived = len(glob.glob(os.path.join(folder, "pace_*")))
        if arrived >= count or time.monotonic() > deadline:
            return arrived
        time.sleep(0.05)
