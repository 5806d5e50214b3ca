"""Env runners on Ray actors: ``vecenv_type: RAY`` or an ``env_runners`` block (``pip install rlchain[ray]``).

The ``num_actors`` envs are split into contiguous slices, one per worker (a Ray actor). Each
worker builds its slice with the local factory (``make_vec_env``, backend ``vecenv_type``; RAY
means auto), env ``i`` of the whole batch seeded ``seed + i`` as the local backends do. The
learner keeps the policy: every step it sends each worker its slice of the batched actions, all
workers step in parallel, and numpy arrays come back (obs, reward, terminated, truncated and the
final observations of the rows that ended); the result obeys the VecEnv contract (vecenv.py).

How the config maps to workers (:func:`worker_slices`): ``vecenv_type: RAY`` alone = 2 workers
(at most ``num_actors``); ``env_runners.num_workers`` and/or ``envs_per_worker`` set the split
(their product must be ``num_actors``); an uneven split gives the first workers one env more.
``env_runners.address``: None starts a local Ray (or uses the one this process already
started), anything else is passed to ``ray.init(address=...)`` to join an existing cluster.

Fault tolerance. A worker that dies (its process killed, its node lost: any Ray error other than
an exception raised by the env itself) or that does not answer within ``step_timeout_s`` is
replaced by a fresh actor with freshly reset envs, seeded apart from every earlier seed. Its
envs' episodes in flight are lost; they are counted (``dropped_episodes``, TensorBoard
``env/dropped_episodes``) and never enter the episode statistics. A worker slot that needs more
than ``max_restarts`` restarts ends the run with a one-line error, and every ``ray.get`` has a
timeout, so a dead cluster ends the run instead of hanging it. An exception raised by an env
is a bug, not a crash: it is re-raised (naming the env index) as the local backends do.

What the learner sees for the rows of a replaced worker (their step was lost: no reward, no
next observation): ``truncated=True``, ``terminated=False``, reward 0, ``final_obs`` = the
observation the policy just acted on, ``obs`` = the first observation of a fresh episode and
``infos['dropped']`` True. Why this is sound for GAE: ``done`` cuts the advantage recursion, so
nothing of the lost episode is chained to the new one. Truncation rather than termination
because the state was not terminal: with ``value_bootstrap`` the target of that step is
``0 + gamma * V(s)`` for the state ``s`` it started from, instead of 0, so the critic is not
taught that ``s`` is worthless. What remains is one made-up step per dropped env with advantage
``-(1 - gamma) V(s)`` (1% of V for gamma 0.99; a terminal target would be all of V), which also
reaches that env's earlier steps of the rollout discounted by ``(gamma * lambda)^k``. A restart
is a rare event, so this bias is negligible; exact removal would need the trainer to mask the row.
"""

from __future__ import annotations

import pickle
import time
from typing import Any

import numpy as np

from rlchain.config.errors import ConfigError
from rlchain.config.run import EnvRunnersConfig
from rlchain.envs.ray.ray_cluster import connect, kill, one_line, release, task_failed
from rlchain.envs.ray.ray_worker import EnvRecipe, EnvWorker
from rlchain.envs.vecenv import DROPPED, StepResult
from rlchain.log import get_logger

log = get_logger(__name__)

VECENV, RUNNERS = "params.config.vecenv_type", "params.config.env_runners"
DEFAULT_WORKERS = 2


def worker_slices(num_envs: int, runners: EnvRunnersConfig) -> list[slice]:
    """The contiguous env slices of the workers (see the module docstring); ConfigError if impossible."""
    workers, per = runners.num_workers, runners.envs_per_worker
    if per is not None:
        if workers is None:
            if num_envs % per:
                raise ConfigError("", f"{RUNNERS}.envs_per_worker", f"num_actors {num_envs} does not divide by "
                                                                    f"envs_per_worker {per}")
            workers = num_envs // per
        elif workers * per != num_envs:
            raise ConfigError("", f"{RUNNERS}.envs_per_worker", f"{workers} workers x {per} envs is not "
                                                                f"num_actors {num_envs}; set one of the two")
    workers = min(DEFAULT_WORKERS, num_envs) if workers is None else workers
    if workers > num_envs:
        raise ConfigError("", f"{RUNNERS}.num_workers", f"{workers} workers for num_actors {num_envs} envs: "
                                                        f"every worker needs at least one env")
    base, extra = divmod(num_envs, workers)
    sizes = [base + (i < extra) for i in range(workers)]
    starts = np.cumsum([0, *sizes])
    return [slice(int(a), int(b)) for a, b in zip(starts[:-1], starts[1:])]


class WorkerLost(RuntimeError):
    """A worker slot needed more than ``max_restarts`` restarts, or could not start: the run stops."""


class RayVecEnv:
    """``num_envs`` envs stepped by Ray actors, one contiguous slice each (see the module docstring).

    ``dropped_episodes`` counts the episodes lost with dead workers, ``restarts[i]`` the restarts of
    worker slot ``i``; ``workers`` are the actor handles (tests kill them).
    """

    def __init__(self, recipe: EnvRecipe, slices: list[slice], seed: int | None, runners: EnvRunnersConfig) -> None:
        import ray

        self._ray, self.recipe, self.slices, self.runners = ray, recipe, slices, runners
        self.num_envs = slices[-1].stop
        self._seed = seed
        self.dropped_episodes = 0
        self.restarts = [0] * len(slices)
        self.workers: list[Any] = []
        self._owns_ray = connect(ray, runners, len(slices))
        self._actor = ray.remote(EnvWorker).options(num_cpus=runners.num_cpus_per_worker, max_restarts=0,
                                                    max_task_retries=0)
        self._last_obs: np.ndarray | None = None
        try:
            self.workers = [self._spawn(i) for i in range(len(slices))]
            info = self._start([w.build.remote(self._slice_seed(seed, i)) for i, w in enumerate(self.workers)])
        except BaseException:
            self.close()
            raise
        self.observation_space, self.action_space = info["observation_space"], info["action_space"]
        self.value_size = info["value_size"]

    # ----- the VecEnv contract --------------------------------------------------------------
    def reset(self, seed: int | None = None) -> np.ndarray:
        """Reset every worker's envs (env ``i`` gets ``seed + i``); returns obs (N, *obs_shape)."""
        if seed is not None:
            self._seed = seed
        seeds = [self._slice_seed(seed, i) for i in range(len(self.workers))]
        outs = self._gather([w.reset.remote(s) for w, s in zip(self.workers, seeds)], "reset")
        for i, out in enumerate(outs):
            if isinstance(out, BaseException):  # a fresh worker's envs are reset already: no episodes lost
                outs[i] = self._restart(i, out, lost=0, seed=seeds[i])
        self._last_obs = np.concatenate(outs)
        return self._last_obs

    def step(self, actions: Any) -> StepResult:
        """Step with actions (N, *action_shape); every worker steps its slice in parallel."""
        if hasattr(actions, "detach"):
            actions = actions.detach().cpu().numpy()
        actions = np.asarray(actions)
        packed = [pickle.dumps(actions[s], protocol=pickle.HIGHEST_PROTOCOL) for s in self.slices]
        outs = self._gather([w.step.remote(a) for w, a in zip(self.workers, packed)], "step")
        dropped = None
        for i, out in enumerate(outs):
            if isinstance(out, BaseException):
                outs[i] = self._cut(i, out)
                dropped = np.zeros(self.num_envs, dtype=bool) if dropped is None else dropped
                dropped[self.slices[i]] = True
            else:
                outs[i] = pickle.loads(out)
        obs = np.concatenate([o[0] for o in outs])
        final_obs = obs.copy()
        for s, o in zip(self.slices, outs):
            final_obs[s.start + o[4]] = o[5]
        game = [None if any(o[k] is None for o in outs) else np.concatenate([o[k] for o in outs]) for k in (6, 7)]
        infos = merge_infos([o[8] for o in outs], self.slices, self.num_envs)
        if dropped is not None:
            infos[DROPPED] = dropped
        self._last_obs = obs
        return StepResult(obs, np.concatenate([o[1] for o in outs]), np.concatenate([o[2] for o in outs]),
                          np.concatenate([o[3] for o in outs]), final_obs, infos, *game)

    def log_stats(self) -> dict[str, float]:
        """TensorBoard counters, written by the trainer every epoch."""
        return {"env/dropped_episodes": float(self.dropped_episodes), "env/worker_restarts": float(sum(self.restarts))}

    def worker_pids(self) -> list[int]:
        """The process id of every worker (for tests and debugging)."""
        return self._ray.get([w.pid.remote() for w in self.workers], timeout=self.runners.step_timeout_s)

    def close(self) -> None:
        """Stop the workers, and the local Ray this env started."""
        release(self._ray, self.workers, self._owns_ray)
        self.workers, self._owns_ray = [], False

    # ----- workers --------------------------------------------------------------------------
    def _spawn(self, i: int) -> Any:
        s = self.slices[i]
        return self._actor.remote(self.recipe, s.start, s.stop - s.start, own_process=True)

    def _slice_seed(self, seed: int | None, i: int) -> int | None:
        return None if seed is None else seed + self.slices[i].start

    def _start(self, futures: list[Any]) -> dict:
        """Wait for the workers' ``build``; a worker that cannot start ends the run with one line."""
        outs = self._gather(futures, "start", self.runners.start_timeout_s)
        for i, out in enumerate(outs):
            if isinstance(out, BaseException):
                raise WorkerLost(f"ray env worker {i} did not start: {one_line(out)}{self._resources_hint(out)}")
        return outs[0]

    def _gather(self, futures: list[Any], what: str, timeout: float | None = None) -> list[Any]:
        """Each worker's result, or the Ray error that replaced it (dead / not answering in time).

        An exception raised by an env (RayTaskError) is re-raised at once as a one-line error.
        """
        ray = self._ray
        deadline = time.monotonic() + (timeout or self.runners.step_timeout_s)
        outs: list[Any] = []
        for i, future in enumerate(futures):
            try:
                outs.append(ray.get(future, timeout=max(0.0, deadline - time.monotonic())))
            except ray.exceptions.RayTaskError as exc:
                s = self.slices[i]
                raise task_failed(exc, what, f"ray env worker {i} (envs {s.start}-{s.stop - 1}) {what}") from None
            except ray.exceptions.GetTimeoutError:
                outs.append(TimeoutError(f"no answer to {what} within {timeout or self.runners.step_timeout_s} s"))
            except ray.exceptions.RayError as exc:
                outs.append(exc)
        return outs

    def _cut(self, i: int, cause: BaseException) -> tuple:
        """A replacement worker's rows for the lost step: truncated, reward 0 (module docstring)."""
        s = self.slices[i]
        n = s.stop - s.start
        obs = self._restart(i, cause, lost=n)
        self.dropped_episodes += n
        zeros = np.zeros(n, dtype=np.float32)
        acted_on = self._last_obs[s] if self._last_obs is not None else obs
        return (obs, zeros, np.zeros(n, dtype=bool), np.ones(n, dtype=bool), np.arange(n), acted_on, zeros,
                np.ones(n, dtype=bool), {})

    def _restart(self, i: int, cause: BaseException, lost: int, seed: int | None = None) -> np.ndarray:
        """Replace worker ``i`` by a fresh actor with reset envs; returns their obs. WorkerLost past max_restarts.

        The envs get ``seed`` (a reset's seed), else one no earlier (re)start used:
        base + N * (restarts so far, all workers) + slice start.
        """
        ray, s, limit = self._ray, self.slices[i], self.runners.max_restarts
        while True:
            self.restarts[i] += 1
            if seed is None and self._seed is not None:
                seed = self._seed + self.num_envs * sum(self.restarts) + s.start
            what = f"ray env worker {i} (envs {s.start}-{s.stop - 1}) failed ({one_line(cause)})"
            if self.restarts[i] > limit:
                raise WorkerLost(f"{what}; it needed more than env_runners.max_restarts = {limit} restarts, "
                                 f"stopping{self._resources_hint(cause)}")
            log.warning(f"rlchain: {what}; restarting it ({self.restarts[i]}/{limit}), {lost} partial episodes "
                        f"dropped")
            kill(ray, self.workers[i])
            self.workers[i] = self._spawn(i)
            out = self._gather([self.workers[i].build.remote(seed)], "start", self.runners.start_timeout_s)[0]
            if not isinstance(out, BaseException):
                out = self._gather([self.workers[i].reset.remote(seed)], "reset")[0]
                if not isinstance(out, BaseException):
                    return out
            cause, lost = out, 0

    def _resources_hint(self, cause: BaseException) -> str:
        """For a worker that never answered (not scheduled?): Ray's free CPUs and what a worker asks."""
        if not isinstance(cause, TimeoutError):
            return ""
        try:
            free = self._ray.available_resources().get("CPU", 0.0)
        except Exception:
            return ""
        return f" (Ray has {free:g} free CPUs; each worker asks env_runners.num_cpus_per_worker = " \
               f"{self.runners.num_cpus_per_worker:g})"


def merge_infos(parts: list[dict], slices: list[slice], n: int) -> dict:
    """The workers' per-env info numbers (:func:`~rlchain.envs.ray.ray_worker.per_env_infos`) as one infos
    dict over all ``n`` envs. A key some worker lacks (a cut worker, an env that reports it only on
    some steps) is NaN in its rows, and a ``_key`` presence mask False there, so readers skip them."""
    out: dict = {}
    keys = {key for part in parts for key in part if key != "final_info"}
    for key in keys:
        mask = key.startswith("_")
        column = np.zeros(n, bool) if mask else np.full(n, np.nan)
        for part, s in zip(parts, slices):
            if key in part:
                column[s] = part[key]
        out[key] = column
    finals = [part.get("final_info", {}) for part in parts]
    if any(finals):
        out["final_info"] = merge_infos(finals, slices, n)
    return out


def make_ray_vec_env(env_name: str, env_config: dict | None, num_envs: int, seed: int | None, kind: str,
                     runners: EnvRunnersConfig | None, render: bool = False) -> RayVecEnv:
    """The factory's entry for ``vecenv_type: RAY`` / ``env_runners``; ConfigError for a bad setup."""
    path = VECENV if kind == "ray" else RUNNERS
    if render:
        raise ConfigError("", path, "rendering needs the envs in this process; play without Ray env runners")
    runners = runners if runners is not None else EnvRunnersConfig()
    slices = worker_slices(num_envs, runners)
    try:
        import ray  # noqa: F401
    except ImportError:
        raise ConfigError("", path, "Ray env runners need ray, which is not installed: "
                                    "pip install rlchain[ray]") from None
    recipe = EnvRecipe.capture(env_name, env_config, "auto" if kind == "ray" else kind)
    return RayVecEnv(recipe, slices, seed, runners)


__all__ = ["EnvRecipe", "EnvWorker", "RayVecEnv", "WorkerLost", "make_ray_vec_env", "worker_slices"]
