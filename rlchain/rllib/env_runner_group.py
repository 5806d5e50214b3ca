"""RLlib's ``EnvRunner`` and ``EnvRunnerGroup`` as a user's code meets them: ``algo.env_runner_group``,
``algo.env_runner`` and the ``env_runner`` / ``env`` / ``rl_module`` arguments of the episode callbacks.

The face steps every env of a run in one place (rlchain's vector env, in this process unless the run asked for
Ray), so it has one env runner: :class:`EnvRunner` holds ``config``, ``env`` (the gymnasium vector env, None
where the envs step on Ray actors), ``num_envs``, ``worker_index`` (0, RLlib's local runner) and ``module``.
``EnvRunnerGroup.foreach_env_runner(func)`` calls ``func`` on it and returns ``[result]``: code that reaches
every env (``runner.env.envs``) reaches all of the run's. Between ``train()`` calls the run is parked, so a
callback's ``on_train_result`` may change the envs (a curriculum's ``set_task``, or ``runner.config.environment(
env_config=...)`` then ``runner.make_env()``, which rebuilds them). What needs RLlib's runner processes (remote
ids, async calls) ends in one line saying what to do.
"""

from __future__ import annotations

from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.envs.wrappers.spaces import wrap_indexed
from rlchain.rllib import envs
from rlchain.rllib.callbacks.callbacks import gymnasium_vector_env
from rlchain.rllib.face_error import FaceNotOffered


class EnvRunner:
    """The face's one env runner of an algorithm (see the module docstring)."""

    worker_index = 0

    def __init__(self, algorithm: Any) -> None:
        self._algorithm = algorithm
        self._module: Any = None
        self._config: Any = None

    @property
    def config(self) -> Any:
        """The runner's own copy of the algorithm's config (not frozen, as RLlib's runner's): a curriculum sets
        ``runner.config.environment(env_config=...)`` and calls :meth:`make_env`."""
        if self._config is None:
            self._config = self._algorithm.config.copy(copy_frozen=False)
        return self._config

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
        """Rebuild the runner's envs from its config's ``env`` / ``env_config`` (RLlib's call after
        ``runner.config.environment(env_config=...)``: a curriculum's next task), then every env starts a fresh
        episode (the episodes in progress are dropped, as RLlib's runner drops them, the episode callbacks' too).
        Single-agent envs stepped
        in this process only (no ``ray.init()``)."""
        vector, algorithm = self.env, self._algorithm
        if vector is None or algorithm._multi is not None:
            raise FaceNotOffered("EnvRunner.make_env: the face rebuilds single-agent envs stepped in this process "
                                 "only (no ray.init(), no MultiAgentEnv); change the envs in place "
                                 "(runner.env.envs[i].unwrapped...) or build a new algorithm with the new env_config")
        s, settings = self.config._settings, algorithm.config._settings
        runners = int(settings.get("num_env_runners") or 0)
        per_runner = max(1, int(settings.get("num_envs_per_env_runner") or 1))
        make, label = envs.env_maker(s["env"], s.get("env_config") or {}, runners, per_runner)
        new = [wrap_indexed(make(i), i) for i in range(len(vector.envs))]  # as rlchain's gymnasium backend wraps
        spaces = (vector.single_observation_space, vector.single_action_space)
        if any((e.observation_space, e.action_space) != spaces for e in new):
            for e in new:
                e.close()
            raise ConfigError(type(self.config).__name__, "env_config", f"make_env: {label} with the new env_config "
                              f"has other spaces than the run's ({spaces[0]}, {spaces[1]}): build a new algorithm")
        for i, old in enumerate(vector.envs):
            old.close()
            vector.envs[i] = new[i]
        algorithm._stepper.context.algorithm.restart_episodes()
        if algorithm._episode_events is not None:  # the episodes the callbacks hold end with the old envs
            algorithm._episode_events.drop_running()

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
