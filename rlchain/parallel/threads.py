"""CPU threads per training phase: the rollout shares the cores with the env's own threads, the
update has them to itself (those that other processes keep idle right now).

envpool (and async/Ray env workers) step on the same cores while the policy acts, so the rollout
keeps torch to a share of them (``torch_threads``, default half the cores); during the update the
envs are idle and the update uses ``update_threads`` (default: every core of the process's share, at
most 4, when ``torch_threads`` is unset too; else the rollout's count).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

import torch

BUSY_SLACK = 0.3
"""Cores' worth of other processes' CPU use below which a core still counts as idle (a shell, a logger)."""


class OtherLoad:
    """How many cores other processes kept busy over an interval: the machine's non-idle CPU time
    (``/proc/stat``) less this process's own (all its threads: torch's, envpool's), per wall second.
    Child processes (async env workers, Ray actors) count as others: they compete for the cores too."""

    def __init__(self, stat: str = "/proc/stat") -> None:
        self.stat = stat
        self.tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
        self.last = self._sample()

    def _sample(self) -> tuple[float, float, float] | None:
        times = _cpu_times(self.stat)
        if times is None:
            return None
        busy = (sum(times) - times[3] - times[4]) / self.tick  # all but idle and iowait, in seconds
        return time.monotonic(), busy, time.process_time()

    def since_last(self) -> float | None:
        """Cores others kept busy since the previous call (None without /proc/stat or under 20 ms)."""
        if self.last is not None and time.monotonic() - self.last[0] < 0.02:
            return None  # too short to tell (SAC alternates phases every step): the next call covers it
        now = self._sample()
        previous, self.last = self.last, now
        if now is None or previous is None:
            return None
        wall = now[0] - previous[0]
        return max(0.0, ((now[1] - previous[1]) - (now[2] - previous[2])) / wall)


def free_cores(cores: int, others: float) -> int:
    """Cores left to this process when others keep ``others`` cores busy (at least 1)."""
    return max(1, cores - math.floor(others + 1.0 - BUSY_SLACK))


@dataclass(frozen=True)
class ThreadPlan:
    """torch intra-op thread counts for the rollout and for the update (CPU training).

    ``rollout`` and ``update`` are the counts on an idle machine. With ``adaptive``, each phase takes
    at most the cores other processes left idle during the same phase last time (measured, not
    guessed from the load average): on 2 cores, two torch threads where another program keeps one
    core busy stall every parallel op of each other (an epoch can take many times longer), so
    a phase drops to one thread while the machine is busy and goes back up when it is idle again.
    ``fixed_update``: the update's count was asked for (``update_threads``) and is kept as it is."""

    rollout: int
    update: int
    adaptive: bool = field(default=False, compare=False)
    fixed_update: bool = field(default=False, compare=False)
    cores: int = field(default_factory=lambda: os.cpu_count() or 1, compare=False)
    _state: dict = field(default_factory=dict, compare=False, repr=False)

    def _others(self) -> OtherLoad:
        if "load" not in self._state:
            self._state["load"] = OtherLoad()
        return self._state["load"]

    def _count(self, phase: str, wanted: int) -> int:
        """``wanted`` capped at the cores others left idle in ``phase`` last time (adaptive plans)."""
        others = self._state.get(phase)
        if not self.adaptive or others is None:
            return wanted
        return min(wanted, free_cores(self.cores, others))

    def _close_phase(self, phase: str) -> None:
        """Attribute the CPU use since the last boundary to ``phase``."""
        if self.adaptive:
            others = self._others().since_last()
            if others is not None:
                self._state[phase] = others

    def _set(self, count: int) -> None:
        if self._state.get("set") != count:  # set_num_threads is not free: only on a change
            torch.set_num_threads(count)
            self._state["set"] = count

    def current(self) -> tuple[int, int]:
        """The (rollout, update) counts the next phases would use."""
        return self._count("rollout", self.rollout), self._count("update", self.update)

    def apply(self) -> None:
        """Set the rollout's thread count (the count outside the update)."""
        if self.adaptive:
            self._others()  # the first interval starts now
        self._state.pop("set", None)
        self._set(self._count("rollout", self.rollout))

    @contextmanager
    def update_phase(self) -> Iterator[None]:
        """Run the block with the update's threads, then go back to the rollout's."""
        self._close_phase("rollout")
        update = self.update if self.fixed_update else self._count("update", self.update)
        if not self.adaptive and update == self.rollout:
            yield
            return
        self._set(update)
        try:
            yield
        finally:
            self._close_phase("update")
            self._set(self._count("rollout", self.rollout))


def plan_threads(torch_threads: int | None, update_threads: int | None, device: str, processes: int = 1,
                 cores: int | None = None, load: float | None = None, updates: bool = True) -> ThreadPlan | None:
    """The thread plan for a process: None on CUDA when nothing was asked for (torch's own choice).
    ``updates=False`` (playing): no gradient updates, so the update keeps the rollout's count and the
    cores are not sampled.

    ``torch_threads`` (rl_games' key) sets the rollout's count, capped at this process's share of
    the cores (``processes`` torchrun ranks share a node); unset, half the share, at most 4, which
    measured fastest for rl-sized networks beside envpool's threads. ``update_threads`` sets the
    update's count (same cap); unset, the update gets the whole share, at most 4 (the envs are idle
    then, so every core can work on the update), unless ``torch_threads`` was set, whose count it then keeps. That
    default also leaves out the cores other processes keep busy (``load``: cores busy now, see :func:`busy_cores`,
    read when not given): an update thread that has to share its core stalls every parallel op of the
    others, and 2 update threads on a 2-core machine at load 5 ran PPO and SAC several times slower
    than 1.
    """
    total = cores or os.cpu_count() or 1
    share = max(1, total // processes)
    if torch_threads is None and update_threads is None and device.startswith("cuda"):
        return None
    adaptive = not device.startswith("cuda")  # CPU phases share the cores with whatever else runs
    rollout = min(torch_threads, share) if torch_threads else max(1, min(4, share // 2))
    if not updates:
        return ThreadPlan(rollout, rollout, adaptive, cores=total)
    if update_threads:
        return ThreadPlan(rollout, min(update_threads, share), adaptive, fixed_update=True, cores=total)
    if torch_threads:
        return ThreadPlan(rollout, rollout, adaptive, cores=total)
    # the first update's count from a sample of the cores busy now; later ones from what others used
    # during the previous update (adaptive), so a run keeps the idle cores it has and gives back the busy ones
    first = max(rollout, min(4, share, idle_cores(total, load)))
    return ThreadPlan(rollout, max(rollout, min(4, share)), adaptive, cores=total,
                      _state={} if first == max(rollout, min(4, share)) else {"update": float(total - first)})


def for_env(plan: ThreadPlan | None, env: object, torch_threads: int | None) -> ThreadPlan | None:
    """``plan`` adjusted to the env it trains on: an env that steps on torch's own threads
    (``steps_on_torch_threads``, rlchain's tensor envs on a CPU) leaves no env threads to share the
    cores with, so its rollout takes the update's count (benchmarks/throughput/throughput.py measures
    it). Unchanged where ``torch_threads`` set the
    rollout's count, and for any other env. Applies the new plan's rollout count."""
    if plan is None or torch_threads or not getattr(env, "steps_on_torch_threads", False) \
            or plan.rollout >= plan.update:
        return plan
    state = dict(plan._state)
    if "update" in state:  # the machine was busy at the start: the rollout starts as the update does
        state["rollout"] = state["update"]
    adjusted = replace(plan, rollout=plan.update, _state=state)
    adjusted.apply()
    return adjusted


def idle_cores(cores: int, load: float | None = None) -> int:
    """Cores not kept busy by other processes: ``cores`` less the whole part of ``load``, the number
    of cores busy right now (:func:`busy_cores`; where ``/proc/stat`` is missing, the 1-minute load
    average; all of them where neither exists). At least 1."""
    if load is None:
        load = recent_busy_cores()
    if load is None:
        try:
            load = os.getloadavg()[0]
        except (AttributeError, OSError):
            return cores
    return max(1, cores - int(load))


SAMPLE_MAX_AGE = 10.0  # seconds a core sample is reused for the next run started in the same process
_last_sample: tuple[float, float | None] | None = None  # (time.monotonic() when taken, busy cores)


def recent_busy_cores(max_age: float | None = None) -> float | None:
    """:func:`busy_cores`, reusing a sample taken in this process less than ``max_age`` seconds ago
    (default :data:`SAMPLE_MAX_AGE`): runs started one after another in one process (a test
    session's ~300 short trainings, a Python-API sweep) pay the 0.2 s sample once every
    ``max_age`` seconds, not once a run."""
    global _last_sample
    max_age = SAMPLE_MAX_AGE if max_age is None else max_age
    now = time.monotonic()
    if _last_sample is not None and now - _last_sample[0] < max_age:
        return _last_sample[1]
    load = busy_cores()
    _last_sample = (time.monotonic(), load)
    return load


def busy_cores(window: float = 0.2, stat: str = "/proc/stat") -> float | None:
    """How many cores other processes keep busy now: the machine's non-idle CPU time over ``window``
    seconds while this process sleeps, in cores; None without ``/proc/stat``.

    Not the 1-minute load average: it still counts a process that ended a minute ago, so a run
    started right after another (a benchmark's next run, a sweep's next trial) saw a load of ~2.7 on
    an idle 2-core machine and took 1 update thread instead of 2 (the PPO update ~37% slower).
    """
    first = _cpu_times(stat)
    if first is None:
        return None
    time.sleep(window)
    second = _cpu_times(stat)
    if second is None:
        return None
    total = sum(second) - sum(first)
    idle = (second[3] + second[4]) - (first[3] + first[4])  # idle + iowait
    if total <= 0:
        return None
    return (os.cpu_count() or 1) * (total - idle) / total


def _cpu_times(stat: str) -> list[int] | None:
    """The aggregate ``cpu`` line of /proc/stat (user nice system idle iowait irq softirq steal ...)."""
    try:
        with open(stat) as fh:
            fields = fh.readline().split()
    except OSError:
        return None
    if len(fields) < 6 or fields[0] != "cpu":
        return None
    return [int(x) for x in fields[1:9]]


def set_threads(torch_threads: int | None, update_threads: int | None, device: str,
                processes: int = 1, updates: bool = True) -> ThreadPlan | None:
    """:func:`plan_threads`, then set its rollout count now; the plan (or None) for the trainer."""
    plan = plan_threads(torch_threads, update_threads, device, processes, updates=updates)
    if plan is not None:
        plan.apply()
    return plan
