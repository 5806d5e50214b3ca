"""RLlib's env runners (``num_env_runners``, ``num_envs_per_env_runner``, ``restart_failed_env_runners``) ->
where rlchain steps the envs.

- Ray: ``num_env_runners > 0`` and Ray is installed and this process asked for it (``ray.init()`` was called,
  or ``RAY_ADDRESS`` names a cluster): rlchain's Ray env runners, one actor per RLlib env runner holding its
  ``num_envs_per_env_runner`` envs (PPO: ``vecenv_type: RAY``, :mod:`rlchain.envs.ray.ray_env`; APPO / IMPALA:
  ``appo.runners: ray``). A dead actor is restarted up to ``max_num_env_runner_restarts`` times when
  ``restart_failed_env_runners`` (RLlib's default), else the run stops at the first failure.
- Otherwise (no Ray, or this process is itself a Ray worker: a Tune trial, an actor or a task, where the
  trial's resource request holds no CPUs for more actors) the same envs are stepped in this process (PPO: one
  vectorized env of ``num_env_runners * num_envs_per_env_runner`` envs; APPO / IMPALA: one runner thread per env
  runner): for cheap envs a round trip to an actor per step costs more than the step, and no Ray start-up is
  paid.
"""

from __future__ import annotations

import os
from typing import Any


def ray_requested() -> bool:
    """Ray is importable and this process started it (``ray.init()``) or names a cluster (``RAY_ADDRESS``), and
    is not a Ray worker itself (see the module docstring)."""
    try:  # optional: ray
        import ray
    except ImportError:
        return False
    if in_ray_worker(ray):
        return False
    return bool(os.environ.get("RAY_ADDRESS")) or bool(ray.is_initialized())


def in_ray_worker(ray: Any) -> bool:
    """This process is a Ray worker (a Tune trial, an actor or a task), not the driver that called ``ray.init()``.
    Asked only once Ray is initialized: ``get_runtime_context()`` would otherwise start Ray."""
    return bool(ray.is_initialized()) and ray.get_runtime_context().worker.mode == ray.WORKER_MODE


def uses_ray(config: Any) -> bool:
    """The config's env runners are Ray actors (see the module docstring)."""
    return int(config._settings.get("num_env_runners") or 0) > 0 and ray_requested()


def restarts(config: Any) -> int:
    """Restarts allowed per env runner: ``max_num_env_runner_restarts`` (RLlib's 1000) when
    ``restart_failed_env_runners``, else 0."""
    s = config._settings
    if not s.get("restart_failed_env_runners", True):
        return 0
    value = s.get("max_num_env_runner_restarts")
    return 1000 if value is None else max(0, int(value))


def env_runners_block(config: Any) -> dict[str, Any]:
    """rlchain's ``env_runners`` block for RLlib's runners (workers, envs each, restarts)."""
    s = config._settings
    runners = max(1, int(s.get("num_env_runners") or 0))
    return {"num_workers": runners, "envs_per_worker": max(1, int(s.get("num_envs_per_env_runner") or 1)),
            "max_restarts": restarts(config)}


def env_runner_keys(config: Any, algo: str) -> dict[str, Any]:
    """The ``params.config`` keys that place ``config``'s envs: PPO on Ray actors (or nothing: in process);
    APPO / IMPALA always have runners (threads or actors, ``appo.runners``, set by their translation)."""
    if algo in ("APPO", "IMPALA"):
        return {"env_runners": env_runners_block(config)}
    if uses_ray(config):
        return {"vecenv_type": "RAY", "env_runners": env_runners_block(config)}
    return {}
