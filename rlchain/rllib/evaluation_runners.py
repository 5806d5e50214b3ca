"""RLlib's evaluation EnvRunners as a ``custom_evaluation_function`` meets them, and the call of that function.

``config.evaluation(custom_evaluation_function=fn)`` makes ``algo.evaluate()`` call ``fn(algo,
algo.eval_env_runner_group)``, as RLlib 2.60 does: ``fn`` returns ``(results, env_steps, agent_steps)`` and logs
its metrics into ``algo.metrics`` under ``("evaluation", "env_runners")``; ``evaluate()`` returns what the metrics
hold under ``"evaluation"`` (RLlib 2.60 reads them there too, and only type-checks the returned dict).

The group holds ``evaluation_num_env_runners`` runners (worker indices 1..n; with 0, one local runner, index 0),
each with ``num_envs_per_env_runner`` envs of the config's env under ``evaluation_config``'s ``env_config``, built
on first use in this process. A runner's ``env`` is a gymnasium ``SyncVectorEnv`` (``env.unwrapped.envs`` reaches
each env, to change its task; the local runner beside remote ones has none, as in RLlib);
``sample(num_episodes=, num_timesteps=, explore=)`` plays its envs from fresh resets with the algorithm's current
module through rlchain's play loop (sampled unless ``explore=False``, as RLlib's: the evaluation config's
``explore``, by default the config's, True) and returns
the finished episodes (``env_steps()``, ``agent_steps()``, ``get_return()``; an episode cut by the step count is
not among them); without a count it plays RLlib's rollout fragment of env steps (``rollout_fragment_length``;
"auto": the train batch over the evaluation runners' envs). ``get_metrics()`` gives RLlib's env-runner metrics of
the episodes finished since its last call.
"""

from __future__ import annotations

from typing import Any

from rlchain.envs.backends.gymnasium_env import GymnasiumVecEnv
from rlchain.policy.play import play
from rlchain.rllib import envs
from rlchain.rllib.callbacks.callbacks import gymnasium_vector_env
from rlchain.rllib.episode_window import episode_metrics
from rlchain.rllib.evaluation_env import evaluation_env_config, evaluation_explore
from rlchain.rllib.face_error import FaceNotOffered


class EvaluationEpisode:
    """One finished evaluation episode, RLlib's episode reads."""

    is_done = True

    def __init__(self, episode_return: float, length: int) -> None:
        self._return, self._length = float(episode_return), int(length)

    def get_return(self) -> float:
        return self._return

    def get_length(self) -> int:
        return self._length

    __len__ = get_length
    env_steps = get_length
    agent_steps = get_length


class EvaluationEnvRunner:
    """One evaluation env runner (see the module docstring)."""

    def __init__(self, algorithm: Any, worker_index: int, make: Any, first: int, num_envs: int,
                 fragment: int) -> None:
        self.worker_index = worker_index
        self._algorithm = algorithm
        # no envs: the local runner beside remote ones, which has no env in RLlib either
        self._fns = [lambda i=i: make(first + i) for i in range(num_envs)]
        self._fragment = fragment
        self._vec: GymnasiumVecEnv | None = None
        self._finished: list[EvaluationEpisode] = []
        self._steps = 0

    @property
    def config(self) -> Any:
        return self._algorithm.config

    @property
    def _envs(self) -> GymnasiumVecEnv:
        if not self._fns:
            raise RuntimeError("the local evaluation env runner has no env beside evaluation_num_env_runners > 0 "
                               "(as in RLlib): foreach_env_runner(..., local_env_runner=False)")
        if self._vec is None:
            self._vec = GymnasiumVecEnv(f"evaluation_runner_{self.worker_index}", len(self._fns), mode="sync",
                                        env_fns=self._fns)
        return self._vec

    @property
    def env(self) -> Any:
        """The runner's gymnasium ``SyncVectorEnv`` (``env.unwrapped.envs[i]``: each env); None for the local
        runner beside remote ones, as in RLlib."""
        return gymnasium_vector_env(self._envs) if self._fns else None

    @property
    def module(self) -> Any:
        return self._algorithm.get_module()

    def sample(self, *, num_timesteps: int | None = None, num_episodes: int | None = None,
               explore: bool | None = None, random_actions: bool = False, force_reset: bool = False,
               **kwargs: Any) -> list[EvaluationEpisode]:
        """The episodes finished in ``num_episodes`` episodes or ``num_timesteps`` env steps (without either,
        RLlib's rollout fragment of each env), played from fresh resets by rlchain's play loop."""
        if random_actions:
            raise FaceNotOffered("EnvRunner.sample(random_actions=True): the face's evaluation runners play the "
                                 "algorithm's module")
        if explore is None:  # RLlib's: the evaluation config's explore, which is the config's (True) unless set
            explore = evaluation_explore(self.config._settings)
        envs = self._envs
        if num_episodes is None and num_timesteps is None:
            num_timesteps = self._fragment * envs.num_envs
        games = None if num_episodes is None else int(num_episodes)
        played: list[EvaluationEpisode] = []
        rounds = None if num_timesteps is None else -(-int(num_timesteps) // envs.num_envs)  # vector steps
        self._algorithm.get_module()  # checks that the algorithm runs
        play(self._algorithm._stepper.context.model, envs, games, deterministic=not explore, steps=rounds,
             on_game=lambda index, reward, length, success: played.append(EvaluationEpisode(reward, length)))
        self._finished += played
        self._steps += rounds * envs.num_envs if rounds is not None and games is None \
            else sum(e.get_length() for e in played)
        return played

    def get_metrics(self) -> dict[str, Any]:
        """RLlib's env-runner metrics of the episodes finished since the last call."""
        done, self._finished = self._finished, []
        steps, self._steps = self._steps, 0
        return {**episode_metrics([(e.get_return(), e.get_length()) for e in done]),
                "num_env_steps_sampled": steps, "num_agent_steps_sampled": steps}

    def stop(self) -> None:
        if self._vec is not None:
            self._vec.close()
            self._vec = None


class EvaluationRunnerGroup:
    """``algo.eval_env_runner_group``: the evaluation env runners (see the module docstring)."""

    def __init__(self, algorithm: Any) -> None:
        s = algorithm.config._settings
        if algorithm._multi is not None:
            raise FaceNotOffered("eval_env_runner_group: the face's evaluation runners play single-agent envs; "
                                 "evaluate a multi-agent run with algo.evaluate() (no custom_evaluation_function)")
        env_config = evaluation_env_config(s)
        remote = int(s.get("evaluation_num_env_runners") or 0)
        per = max(1, int(s.get("num_envs_per_env_runner") or 1))
        make, _ = envs.env_maker(s["env"], env_config, remote, per)
        fragment = s.get("rollout_fragment_length")  # "auto": the train batch over the (evaluation) runners' envs
        fragment = int(fragment) if isinstance(fragment, int) else \
            -(-algorithm.config.total_train_batch_size // (max(1, remote) * per))
        self.local_env_runner = EvaluationEnvRunner(algorithm, 0, make, 0, 0 if remote else per, fragment)
        self._remote = [EvaluationEnvRunner(algorithm, i + 1, make, i * per, per, fragment) for i in range(remote)]

    def _runners(self, local: bool) -> list[EvaluationEnvRunner]:
        return ([self.local_env_runner] if local or not self._remote else []) + self._remote

    def foreach_env_runner(self, func: Any, *, local_env_runner: bool = True, healthy_only: bool = True,
                           remote_worker_ids: Any = None, timeout_seconds: Any = None,
                           return_obj_refs: bool = False, mark_healthy: bool = False, kwargs: Any = None
                           ) -> list[Any]:
        """``[func(runner) for each runner]`` (the local one first when ``local_env_runner``; it is the only one
        without evaluation runners); ``func`` a callable or a method name."""
        if return_obj_refs:
            raise FaceNotOffered("foreach_env_runner(return_obj_refs=True): the face's runners are in this process")
        runners = self._runners(local_env_runner)
        if remote_worker_ids:
            runners = [r for r in runners if r.worker_index in set(remote_worker_ids)]
        call = (lambda r: getattr(r, func)(**(kwargs or {}))) if isinstance(func, str) \
            else (lambda r: func(r, **(kwargs or {})))
        return [call(r) for r in runners]

    def num_remote_env_runners(self) -> int:
        return len(self._remote)

    num_healthy_remote_env_runners = num_remote_env_runners
    num_healthy_remote_workers = num_remote_env_runners

    def healthy_env_runner_ids(self) -> list[int]:
        return [r.worker_index for r in self._remote]

    def sync_weights(self, *args: Any, **kwargs: Any) -> None:
        """The runners act with the algorithm's module itself: nothing to sync."""

    def stop(self) -> None:
        for runner in self._runners(True):
            runner.stop()


def group(algorithm: Any) -> EvaluationRunnerGroup:
    """The algorithm's evaluation runner group, made on first use."""
    found = algorithm.__dict__.get("_eval_group")
    if found is None:
        found = algorithm.__dict__["_eval_group"] = EvaluationRunnerGroup(algorithm)
    return found


def close(algorithm: Any) -> None:
    found = algorithm.__dict__.pop("_eval_group", None)
    if found is not None:
        found.stop()


def evaluate_custom(algorithm: Any, func: Any) -> dict[str, Any]:
    """``algo.evaluate()`` with a ``custom_evaluation_function``: its return checked as RLlib 2.60 checks it,
    then what the function logged under ``"evaluation"`` (RLlib's evaluation results)."""
    name = getattr(func, "__name__", repr(func))
    out = func(algorithm, group(algorithm))
    if not (isinstance(out, tuple) and len(out) == 3):
        raise ValueError(f"custom_evaluation_function {name}: expected (results dict, env_steps, agent_steps), "
                         f"got {type(out).__name__}")
    results, env_steps, agent_steps = out
    if not isinstance(env_steps, int) or not isinstance(agent_steps, int):
        raise ValueError(f"custom_evaluation_function {name}: env_steps and agent_steps must be ints, got "
                         f"{env_steps!r}, {agent_steps!r}")
    if not isinstance(results, dict):
        raise ValueError(f"custom_evaluation_function {name}: expected a dict of metrics, got {results!r}")
    return algorithm.metrics.peek("evaluation", default={})
