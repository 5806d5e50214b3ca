"""CPU threads per training phase: the rollout shares the cores with the env's own threads, the
update has them to itself (those that other processes leave idle).

envpool (and async/Ray env workers) step on the same cores while the policy acts, so the rollout
keeps torch to a share of them (``torch_threads``, default half the cores); during the update the
envs are idle and the update uses ``update_threads`` (default: every core of the process's share, at
most 4, when ``torch_threads`` is unset too; else the rollout's count).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import torch


@dataclass(frozen=True)
class ThreadPlan:
    """torch intra-op thread counts for the rollout and for the update (CPU training)."""

    rollout: int
    update: int

    def apply(self) -> None:
        """Set the rollout's thread count (the count outside the update)."""
        torch.set_num_threads(self.rollout)

    @contextmanager
    def update_phase(self) -> Iterator[None]:
        """Run the block with ``update`` threads, then go back to ``rollout`` threads."""
        if self.update == self.rollout:
            yield
            return
        torch.set_num_threads(self.update)
        try:
            yield
        finally:
            torch.set_num_threads(self.rollout)


def plan_threads(torch_threads: int | None, update_threads: int | None, device: str, processes: int = 1,
                 cores: int | None = None, load: float | None = None) -> ThreadPlan | None:
    """The thread plan for a process: None on CUDA when nothing was asked for (torch's own choice).

    ``torch_threads`` (rl_games' key) sets the rollout's count, capped at this process's share of
    the cores (``processes`` torchrun ranks share a node); unset, half the share, at most 4, which
    measured fastest for rl-sized networks beside envpool's threads. ``update_threads`` sets the
    update's count (same cap); unset, the update gets the whole share, at most 4 (the envs are idle
    then: 2 threads on 2 cores measured 1.10-1.17x PPO train steps/s on envpool HalfCheetah, Ant and
    Hopper and 1.26x SAC fps), unless ``torch_threads`` was set, whose count it then keeps. That
    default also leaves out the cores other processes keep busy (``load``: the 1-minute load average,
    read when not given): an update thread that has to share its core stalls every parallel op of the
    others, and 2 update threads on a 2-core machine at load 5 ran PPO and SAC several times slower
    than 1.
    """
    total = cores or os.cpu_count() or 1
    share = max(1, total // processes)
    if torch_threads is None and update_threads is None and device.startswith("cuda"):
        return None
    rollout = min(torch_threads, share) if torch_threads else max(1, min(4, share // 2))
    if update_threads:
        update = min(update_threads, share)
    else:
        update = rollout if torch_threads else max(rollout, min(4, share, idle_cores(total, load)))
    return ThreadPlan(rollout, update)


def idle_cores(cores: int, load: float | None = None) -> int:
    """Cores not kept busy by other processes: ``cores`` less the whole part of the 1-minute load
    average (at least 1; all of them where the platform has no load average)."""
    if load is None:
        try:
            load = os.getloadavg()[0]
        except (AttributeError, OSError):
            return cores
    return max(1, cores - int(load))


def set_threads(torch_threads: int | None, update_threads: int | None, device: str,
                processes: int = 1) -> ThreadPlan | None:
    """:func:`plan_threads`, then set its rollout count now; the plan (or None) for the trainer."""
    plan = plan_threads(torch_threads, update_threads, device, processes)
    if plan is not None:
        plan.apply()
    return plan
