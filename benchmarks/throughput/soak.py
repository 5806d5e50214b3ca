"""Soak benchmark: train one config for a set wall time; report resident memory and fps every interval.

    python benchmarks/throughput/soak.py --minutes 30 [--config rlchain/configs/ppo_cartpole.yaml] [--interval 60]

Memory must stay flat after warm-up (growth under 5% between the first report after warm-up and
the last) and fps steady; the verdict line says whether it did.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain and benchmarks first
    sys.path.insert(0, ROOT)


def rss_mib() -> float:
    """Resident set size of this process in MiB (Linux /proc)."""
    with open("/proc/self/statm") as fh:
        pages = int(fh.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


class Reporter:
    """Epoch callback: prints one line per interval and keeps the samples."""

    def __init__(self, interval: float, deadline: float) -> None:
        self.interval, self.deadline = interval, deadline
        self.start = time.time()
        self.next = self.start + interval
        self.last_frames, self.last_time = 0, self.start
        self.samples: list[tuple[float, float, float]] = []

    def __call__(self, trainer, stats, episodes) -> None:
        now = time.time()
        if now >= self.next:
            fps = (trainer.frames - self.last_frames) / (now - self.last_time)
            self.samples.append((now - self.start, rss_mib(), fps))
            print(f"{(now - self.start) / 60:6.1f} min | rss {rss_mib():8.1f} MiB | fps {fps:8.0f} | "
                  f"frames {trainer.frames} | epoch {trainer.epoch}", flush=True)
            self.last_frames, self.last_time, self.next = trainer.frames, now, now + self.interval
        if now >= self.deadline:
            trainer.request_stop("soak time limit")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--config", default=os.path.join(ROOT, "rlchain", "configs", "ppo_cartpole.yaml"))
    p.add_argument("--minutes", type=float, default=30.0)
    p.add_argument("--interval", type=float, default=60.0, help="seconds between reports")
    p.add_argument("--warmup", type=int, default=2, help="reports to skip before judging memory")
    args = p.parse_args()

    from rlchain import Runner

    with tempfile.TemporaryDirectory() as tmp:
        overrides = ["params.config.max_epochs=-1", "params.config.max_frames=-1",
                     "params.config.score_to_win=1e12", "params.config.print_stats=false",
                     f"params.config.train_dir={tmp}", "params.config.save_frequency=50"]
        reporter = Reporter(args.interval, time.time() + args.minutes * 60)
        Runner().load(args.config, overrides).train(callbacks=[reporter])
    samples = reporter.samples[args.warmup:]
    if len(samples) < 2:
        print("too short to judge: run longer than (warmup + 2) intervals")
        return 1
    growth = (samples[-1][1] - samples[0][1]) / samples[0][1] * 100
    fps = [s[2] for s in samples]
    spread = (max(fps) - min(fps)) / (sum(fps) / len(fps)) * 100
    ok = growth < 5
    print(f"memory after warm-up: {samples[0][1]:.1f} -> {samples[-1][1]:.1f} MiB ({growth:+.1f}%), "
          f"fps {min(fps):.0f}..{max(fps):.0f} (spread {spread:.0f}%): {'FLAT' if ok else 'GROWING'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
