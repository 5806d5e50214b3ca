"""appo / impala runners as threads of this process (``appo.runners: local``): no Ray needed.

Each runner thread loops: pick up the latest weights, sample a fragment, queue it (waiting while
the queue is full). Threads share one Python interpreter, so this pays where the env step leaves
the GIL (envpool, simulators in C, envs that wait on I/O or a sleep); pure-Python envs step one at
a time (docs/appo.md).

Fault tolerance as the Ray runners have it: a runner that dies (:class:`RunnerKilled`) or delivers
no fragment within ``fragment_timeout_s`` is replaced by a fresh one with freshly reset envs (a
hung thread cannot be killed: it is abandoned, and what it sends later is dropped); its fragment
in progress is counted in ``lost_fragments``. More than ``max_restarts`` restarts of one runner
end the run with a one-line :class:`~rlchain.envs.ray.ray_env.WorkerLost`. An exception raised by an
env is a bug, not a crash: it ends the run naming the runner.
"""

from __future__ import annotations

import copy
import threading
import time
from typing import Any

import torch

from rlchain.algos.appo.fragments import FragmentRunner, RunnerKilled
from rlchain.algos.appo.runner_pool import RunnerPool
from rlchain.envs.ray.ray_cluster import one_line


class LocalRunners(RunnerPool):
    """Runner threads in this process (see the module docstring)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.runners: list[FragmentRunner] = []
        self.threads: list[threading.Thread | None] = [None] * self.num_workers
        self.generation = [0] * self.num_workers  # a replaced runner's thread sees its generation move on
        self.last_fragment: list[float | None] = [0.0] * self.num_workers  # None: waiting on the queue
        self.failures: list[BaseException | None] = [None] * self.num_workers
        self._model: torch.nn.Module | None = None
        try:
            for i in range(self.num_workers):
                runner = self._make_runner(i)
                info = runner.build(self.slice_seed(i))
                self.runners.append(runner)
            self.set_spaces(info)
        except BaseException:
            self.close()
            raise

    def _make_runner(self, i: int) -> FragmentRunner:
        s = self.slices[i]
        return FragmentRunner(self.recipe, i, s.start, s.stop - s.start, self.horizon, self.step_delays[i])

    def start(self, model: torch.nn.Module, weights: dict, version: int) -> None:
        self._model = copy.deepcopy(model).to("cpu")
        self.publish(weights, version)
        for i in range(self.num_workers):
            self._launch(i)
        self.started = True

    def _launch(self, i: int) -> None:
        runner = self.runners[i]
        weights, version = self._latest
        runner.set_policy(copy.deepcopy(self._model), weights, version)
        self.last_fragment[i] = time.monotonic()
        self.failures[i] = None
        thread = threading.Thread(target=self._run, args=(i, runner, self.generation[i]),
                                  name=f"rlchain-runner-{i}", daemon=True)
        self.threads[i] = thread
        thread.start()

    def _run(self, i: int, runner: FragmentRunner, generation: int) -> None:
        """The thread body: fragments until the pool stops or this runner is replaced."""
        try:
            while not self.stopping.is_set() and self.generation[i] == generation:
                weights, version = self._latest
                if version != runner.version:
                    runner.load_weights(weights, version)
                fragment = runner.sample()
                if self.generation[i] != generation:
                    return  # replaced while it sampled (hung): its fragment is not wanted
                self.last_fragment[i] = None  # waiting for room in the queue is not hanging
                if not self.put(fragment, cancelled=lambda: runner.killed):
                    if runner.killed:
                        raise RunnerKilled(f"runner {i} killed")
                    return
                self.last_fragment[i] = time.monotonic()
        except BaseException as exc:
            if self.generation[i] == generation:
                self.failures[i] = exc

    def watch(self) -> None:
        """Replace runners that died or hung; an env's own exception ends the run (one line)."""
        if not self.started or self.stopping.is_set():
            return
        now = time.monotonic()
        for i, thread in enumerate(self.threads):
            cause = self.failures[i]
            if cause is not None and not isinstance(cause, RunnerKilled):
                s = self.slices[i]
                self.error = RuntimeError(f"appo runner {i} (envs {s.start}-{s.stop - 1}): {one_line(cause)}")
                raise self.error
            if cause is None and thread is not None and thread.is_alive():
                since = self.last_fragment[i]
                if since is None or now - since <= self.fragment_timeout_s:
                    continue
                cause = TimeoutError(f"no fragment within {self.fragment_timeout_s:g} s")
                self.runners[i].kill()  # a hung thread stops at its next step, if it ever steps again
            elif cause is None:
                continue
            self._restart(i, cause)

    def _restart(self, i: int, cause: BaseException) -> None:
        self.count_restart(i, cause, "appo runner")
        self.generation[i] += 1
        old, old_thread = self.runners[i], self.threads[i]
        runner = self._make_runner(i)
        runner.build(self.slice_seed(i, sum(self.restarts)))
        self.runners[i] = runner
        self._launch(i)
        if old_thread is None or not old_thread.is_alive():  # a hung thread may still use its envs
            old.close()

    def kill(self, i: int) -> None:
        """Kill runner ``i`` in the middle of its fragment (tests: a runner that dies)."""
        self.runners[i].kill()

    def close(self) -> None:
        self.stopping.set()
        for runner in self.runners:
            runner.kill()  # a runner in a step delay wakes up
        for thread in self.threads:
            if thread is not None:
                thread.join(timeout=5.0)
        for runner, thread in zip(self.runners, self.threads):
            if thread is None or not thread.is_alive():  # a hung thread may still use its envs
                runner.close()
