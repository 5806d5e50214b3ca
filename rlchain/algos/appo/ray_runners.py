"""appo / impala runners on Ray actors (``appo.runners: ray``; ``env_runners.address`` names a cluster).

Each actor is a :class:`~rlchain.algos.appo.fragments.FragmentRunner` with its own envs and a CPU
policy copy. A feeder thread in the learner process keeps exactly one ``sample`` call in flight
per actor: when a fragment comes back it asks that actor for the next one at once (new weights
travel with the call, through the object store, when the version moved on) and queues the
fragment for the learner, waiting while the queue is full (backpressure: at most one fragment per
actor beyond the queue). The learner never waits for a particular actor, so a straggler slows only
its own share.

Fault tolerance as :mod:`rlchain.envs.ray.ray_env` has it, on the same Ray plumbing (``connect``,
``one_line``, ``WorkerLost``): an actor that dies or delivers nothing within
``appo.fragment_timeout_s`` is killed and replaced by a fresh one (fresh envs, seeded apart), its
fragment in progress counted in ``lost_fragments``; past ``env_runners.max_restarts`` restarts of
one actor the run ends with one line. An exception raised by an env is a bug: it ends the run.
"""

from __future__ import annotations

import copy
import threading
import time
from typing import Any

import torch

from rlchain.algos.appo.fragments import FragmentRunner
from rlchain.algos.appo.runner_pool import RunnerPool
from rlchain.config.run import EnvRunnersConfig
from rlchain.envs.ray.ray_cluster import connect, kill, one_line, release, task_failed
from rlchain.envs.ray.ray_env import WorkerLost


class RayRunners(RunnerPool):
    """Fragment runners on Ray actors (see the module docstring); ``workers`` are the actor handles."""

    def __init__(self, *args: Any, runners: EnvRunnersConfig, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        import ray

        self._ray, self.runners = ray, runners
        self.workers: list[Any] = []
        self._model_ref: Any = None
        self._sent = [-1] * self.num_workers  # the weights version each actor has
        self._feeder: threading.Thread | None = None
        self._owns_ray = connect(ray, runners, self.num_workers)
        self._actor = ray.remote(FragmentRunner).options(num_cpus=runners.num_cpus_per_worker, max_restarts=0,
                                                         max_task_retries=0)
        try:
            self.workers = [self._spawn(i) for i in range(self.num_workers)]
            infos = [self._wait(w.build.remote(self.slice_seed(i), True), i, "start", runners.start_timeout_s)
                     for i, w in enumerate(self.workers)]
            for i, info in enumerate(infos):
                if isinstance(info, BaseException):
                    raise WorkerLost(f"appo ray runner {i} did not start: {one_line(info)}")
            self.set_spaces(infos[0])
        except BaseException:
            self.close()
            raise

    def _spawn(self, i: int) -> Any:
        s = self.slices[i]
        return self._actor.remote(self.recipe, i, s.start, s.stop - s.start, self.horizon, self.step_delays[i])

    def _wait(self, future: Any, i: int, what: str, timeout: float) -> Any:
        """The call's result, or the Ray error / TimeoutError that replaced it; an env's own error raises."""
        ray = self._ray
        try:
            return ray.get(future, timeout=timeout)
        except ray.exceptions.RayTaskError as exc:
            s = self.slices[i]
            raise task_failed(exc, what, f"appo ray runner {i} (envs {s.start}-{s.stop - 1}) {what}") from None
        except ray.exceptions.GetTimeoutError:
            return TimeoutError(f"no answer to {what} within {timeout:g} s")
        except ray.exceptions.RayError as exc:
            return exc

    # ----- the learner's side ---------------------------------------------------------------
    def start(self, model: torch.nn.Module, weights: dict, version: int) -> None:
        self._model_ref = self._ray.put(copy.deepcopy(model).to("cpu"))
        self.publish(weights, version)
        for i in range(self.num_workers):
            self._give_policy(i)
        self._feeder = threading.Thread(target=self._feed, name="rlchain-appo-feeder", daemon=True)
        self._feeder.start()
        self.started = True

    def publish(self, weights: dict, version: int) -> None:
        """Weights go to the object store once; every actor's next sample call carries the reference."""
        self._latest = (self._ray.put(weights), version)

    def _give_policy(self, i: int) -> None:
        ref, version = self._latest
        out = self._wait(self.workers[i].set_policy.remote(self._model_ref, ref, version), i, "start",
                         self.runners.start_timeout_s)
        if isinstance(out, BaseException):
            raise WorkerLost(f"appo ray runner {i} did not take the policy: {one_line(out)}")
        self._sent[i] = version

    def _feed(self) -> None:
        """The feeder thread: one call in flight per actor (a fragment, or a replacement's start), fragments
        into the queue. A replacement starts in the background: the other actors' fragments keep flowing."""
        ray = self._ray
        in_flight: dict[Any, tuple[int, str, float]] = {}  # call -> (actor, "sample" or "start", when sent)
        try:
            for i in range(self.num_workers):
                self._submit(i, in_flight)
            resumed = time.monotonic()  # while the queue was full nobody waited on the actors
            while not self.stopping.is_set():
                ready, _ = ray.wait(list(in_flight), num_returns=len(in_flight), timeout=0.1)
                for ref in ready:
                    i, kind, _ = in_flight.pop(ref)
                    out = self._wait(ref, i, kind, self.runners.start_timeout_s)  # ready: no waiting
                    if isinstance(out, BaseException):
                        self._replace(i, out, in_flight, lost=kind == "sample")
                        continue
                    if kind == "start":
                        self._sent[i] = out
                    self._submit(i, in_flight)
                    if kind == "sample":
                        was_full = self.fragments.full()
                        if not self.put(out):
                            return
                        if was_full:
                            resumed = time.monotonic()
                now = time.monotonic()
                for ref, (i, kind, since) in list(in_flight.items()):
                    limit = self.fragment_timeout_s if kind == "sample" else self.runners.start_timeout_s
                    if now - (max(since, resumed) if kind == "sample" else since) > limit:
                        del in_flight[ref]
                        what = "fragment" if kind == "sample" else "start"
                        self._replace(i, TimeoutError(f"no {what} within {limit:g} s"), in_flight,
                                      lost=kind == "sample")
        except BaseException as exc:  # seen by the learner at its next get()
            if not self.stopping.is_set():
                self.error = exc

    def _submit(self, i: int, in_flight: dict) -> None:
        """The next fragment of actor ``i``; new weights ride along when the version moved on."""
        ref, version = self._latest
        worker = self.workers[i]
        if self._sent[i] != version:
            call = worker.sample.remote(ref, version)
            self._sent[i] = version
        else:
            call = worker.sample.remote()
        in_flight[call] = (i, "sample", time.monotonic())

    def _replace(self, i: int, cause: BaseException, in_flight: dict, lost: bool) -> None:
        """Kill actor ``i`` and start a fresh one (fresh envs, the latest weights) in the background;
        WorkerLost past max_restarts."""
        ray = self._ray
        self.count_restart(i, cause, "appo ray runner", lost)
        kill(ray, self.workers[i])
        self.workers[i] = self._spawn(i)
        ref, version = self._latest
        self._sent[i] = -1
        call = self.workers[i].start.remote(self.slice_seed(i, sum(self.restarts)), True, self._model_ref, ref,
                                            version)
        in_flight[call] = (i, "start", time.monotonic())

    def worker_pids(self) -> list[int]:
        return self._ray.get([w.pid.remote() for w in self.workers], timeout=self.runners.step_timeout_s)

    def close(self) -> None:
        self.stopping.set()
        if self._feeder is not None:
            self._feeder.join(timeout=10.0)
        release(self._ray, self.workers, self._owns_ray)
        self.workers, self._owns_ray = [], False
