"""What the appo / impala learner sees of its runners: a bounded queue of fragments and a weight slot.

:class:`RunnerPool` is shared by the local runners (threads, :mod:`rlchain.algos.appo.local_runners`)
and the Ray runners (actors, :mod:`rlchain.algos.appo.ray_runners`). Runners put fragments into a
queue of ``learner_queue_size``; a full queue makes them wait (backpressure: memory stays bounded
by the queue plus one fragment per runner). The learner takes fragments with :meth:`get` and
publishes new weights with :meth:`publish`; runners pick the latest up between fragments.

It also stands in for the training env towards the Loop: ``num_envs``, the spaces, ``reset``
(starts the runners), ``log_stats`` (restart and drop counters) and ``close``.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from typing import Any

import torch

from rlchain.algos.appo.fragments import Fragment
from rlchain.envs.ray.ray_cluster import one_line
from rlchain.envs.ray.ray_env import WorkerLost
from rlchain.envs.ray.ray_worker import EnvRecipe
from rlchain.log import get_logger

log = get_logger(__name__)


class RunnerPool:
    """The fragment queue, the latest weights, the counters; subclasses start and watch the runners."""

    def __init__(self, recipe: EnvRecipe, slices: list[slice], seed: int | None, horizon: int,
                 queue_size: int, max_restarts: int, fragment_timeout_s: float,
                 step_delays: list[float] | None = None) -> None:
        self.recipe, self.slices, self.seed, self.horizon = recipe, slices, seed, horizon
        self.num_envs = slices[-1].stop
        self.num_workers = len(slices)
        self.max_restarts, self.fragment_timeout_s = max_restarts, fragment_timeout_s
        self.step_delays = list(step_delays) if step_delays else [0.0] * len(slices)
        self.fragments: queue.Queue[Fragment] = queue.Queue(maxsize=queue_size)
        self.restarts = [0] * len(slices)
        self.lost_fragments = 0  # fragments in progress on runners that died or hung
        self.error: BaseException | None = None  # a failure the learner must see (raised by get)
        self.stopping = threading.Event()
        self._latest: tuple[dict | None, int] = (None, 0)
        self.observation_space: Any = None
        self.action_space: Any = None
        self.value_size = 1
        self.started = False

    # ----- the learner's side ---------------------------------------------------------------
    def start(self, model: torch.nn.Module, weights: dict, version: int) -> None:
        """Give every runner a copy of ``model`` with ``weights`` and let them sample."""
        raise NotImplementedError

    def publish(self, weights: dict, version: int) -> None:
        """New weights (CPU tensors) for the runners, picked up at their next fragment."""
        self._latest = (weights, version)

    def get(self, timeout: float) -> Fragment | None:
        """The next fragment, or None after ``timeout`` s; raises a runner failure the run cannot survive."""
        if self.error is not None:
            raise self.error
        self.watch()
        try:
            return self.fragments.get(timeout=timeout)
        except queue.Empty:
            if self.error is not None:
                raise self.error from None
            return None

    def drain(self) -> int:
        """Throw away the fragments waiting (after a rollback); returns how many."""
        count = 0
        while True:
            try:
                self.fragments.get_nowait()
                count += 1
            except queue.Empty:
                return count

    def queue_size(self) -> int:
        return self.fragments.qsize()

    def watch(self) -> None:
        """Replace dead or hung runners (called by :meth:`get`)."""

    # ----- what the Loop asks of an env -----------------------------------------------------
    def reset(self, seed: int | None = None) -> None:
        """The runners reset their own envs; nothing to return to the Loop."""
        return None

    def log_stats(self) -> dict[str, float]:
        return {"appo/runner_restarts": float(sum(self.restarts)), "appo/lost_fragments": float(self.lost_fragments)}

    def close(self) -> None:
        raise NotImplementedError

    # ----- helpers for the subclasses -------------------------------------------------------
    def put(self, fragment: Fragment, cancelled: Callable[[], bool] = lambda: False) -> bool:
        """Queue a fragment, waiting while the queue is full; False if the pool stops (or ``cancelled()``
        turns true) meanwhile."""
        while not self.stopping.is_set() and not cancelled():
            try:
                self.fragments.put(fragment, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def count_restart(self, i: int, cause: BaseException, label: str, lost: bool = True) -> None:
        """Runner ``i`` (``label``: what the lines call it) failed and is restarted: counted, with its fragment in
        progress when ``lost``, and said in one line; past ``max_restarts`` the run ends with a WorkerLost."""
        s, limit = self.slices[i], self.max_restarts
        self.restarts[i] += 1
        self.lost_fragments += int(lost)
        what = f"{label} {i} (envs {s.start}-{s.stop - 1}) failed ({one_line(cause)})"
        if self.restarts[i] > limit:
            self.error = WorkerLost(f"{what}; it needed more than env_runners.max_restarts = {limit} restarts, "
                                    f"stopping")
            raise self.error
        dropped = ", its fragment dropped" if lost else ""
        log.warning(f"rlchain: {what}; restarting it ({self.restarts[i]}/{limit}){dropped}")

    def slice_seed(self, i: int, restart: int = 0) -> int | None:
        """Env seeds of runner ``i``: env j of the batch gets seed + j; a restart moves them past every earlier one."""
        if self.seed is None:
            return None
        return self.seed + self.num_envs * restart + self.slices[i].start

    def set_spaces(self, info: dict) -> None:
        self.observation_space, self.action_space = info["observation_space"], info["action_space"]
        self.value_size = info["value_size"]
