"""RLlib's ``EnvRunner`` and ``EnvRunnerGroup`` as a user's code meets them: ``algo.env_runner_group``,
``algo.env_runner`` and the ``env_runner`` / ``env`` / ``rl_module`` arguments of the episode callbacks.

The face steps every env of a run in one place (rlchain's vector env, in this process unless the run asked for
Ray), so it has one env runner: :class:`EnvRunner` holds ``config``, ``env`` (the gymnasium vector env, None
where the envs step on Ray actors), ``num_envs``, ``worker_index`` (0, RLlib's local runner) and ``module``.
``EnvRunnerGroup.foreach_env_runner(func)`` calls ``func`` on it and returns ``[result]``: code that reaches
every env (``runner.env.envs``) reaches all of the run's. Between ``train()`` calls the run is parked, so a
callback's ``on_train_result`` may change the envs (a curriculum's ``set_task``). What needs RLlib's runner
processes (rebuilding envs with ``make_env()``, remote ids, async calls) ends in one line saying what to do.
"""

from __future__ import annotations

from typing import Any

from rlchain.rllib.callbacks.callbacks import gymnasium_vector_env
from rlchain.rllib.face_error import FaceNotOffered


class EnvRunner:
    """The face's one env runner of an algorithm (see the module docstring)."""

    worker_index = 0

    def __init__(self, algorithm: Any) -> None:
        self._algorithm = algorithm
        self._module: Any = None

    @property
    def config(self) -> Any:
        return self._algorithm.config

    @property
    def env(self) -> Any:
        ctx = self._algorithm._stepper.context
        return gymnasium_vector_env(ctx.training_env) if ctx is not None else None

    @property
    def num_envs(self) -> int:
        env = self.env
        if env is not None:
            return int(env.num_envs)
        s = self._algorithm.config._settings
        return max(1, int(s.get("num_env_runners") or 0)) * max(1, int(s.get("num_envs_per_env_runner") or 1))

    @property
    def module(self) -> Any:
        if self._module is None:
            self._module = self._algorithm.get_module()
        return self._module

    def make_env(self) -> None:
        raise FaceNotOffered("EnvRunner.make_env: the face builds a run's envs once; change them in place "
                             "(runner.env.envs[i].unwrapped...) or build a new algorithm with the new env_config")

    def foreach_env(self, func: Any) -> list[Any]:
        """``func(env)`` for each gymnasium env of the vector env (RLlib's older runner method)."""
        env = self.env
        if env is None:
            raise FaceNotOffered("EnvRunner.foreach_env: the envs step on Ray env runners, out of this process; "
                                 "call it without ray.init() (in-process envs)")
        return [func(e) for e in env.envs]


class EnvRunnerGroup:
    """``algo.env_runner_group``: the face's one :class:`EnvRunner` (see the module docstring)."""

    def __init__(self, algorithm: Any) -> None:
        self._algorithm = algorithm
        self.local_env_runner = EnvRunner(algorithm)

    def foreach_env_runner(self, func: Any, *, local_env_runner: bool = True, healthy_only: bool = True,
                           remote_worker_ids: Any = None, timeout_seconds: Any = None,
                           return_obj_refs: bool = False, mark_healthy: bool = False, kwargs: Any = None
                           ) -> list[Any]:
        """``[func(runner)]`` (``func`` a callable or a method name, or a list of them)."""
        if return_obj_refs or remote_worker_ids:
            raise FaceNotOffered("foreach_env_runner(return_obj_refs / remote_worker_ids): the face's env runner "
                                 "is in this process; call it with func alone")
        runner = self.local_env_runner
        funcs = func if isinstance(func, list) else [func]
        out = []
        for f in funcs:
            out.append(getattr(runner, f)(**(kwargs or {})) if isinstance(f, str) else f(runner, **(kwargs or {})))
        return out

    def foreach_env(self, func: Any) -> list[list[Any]]:
        return [self.local_env_runner.foreach_env(func)]

    def num_healthy_remote_env_runners(self) -> int:
        return 0

    def num_remote_env_runners(self) -> int:
        return 0

    def healthy_env_runner_ids(self) -> list[int]:
        return []

    def sync_weights(self, *args: Any, **kwargs: Any) -> None:
        """The face's runner acts with the learner's module itself: nothing to sync."""

    def foreach_worker(self, *args: Any, **kwargs: Any) -> None:
        raise FaceNotOffered("EnvRunnerGroup.foreach_worker is RLlib's old name (gone in 2.60): use "
                             "foreach_env_runner(lambda runner: ...)")
