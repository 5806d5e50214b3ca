"""RLlib's ``Algorithm`` on rlchain's loop: ``train()`` runs one rlchain epoch (``train_batch_size`` env steps)
and returns RLlib's result dict; ``evaluate()``, ``save_to_path()`` / ``restore_from_path()`` /
``Algorithm.from_checkpoint()`` (rlchain's checkpoint through its one loader), ``get_module()``,
``compute_single_action()``, ``stop()``.

The run is rlchain's ``Runner.train`` in a background thread paced by
:class:`rlchain.tuning.epochs.EpochStepper`: it parks before the first rollout (so the module exists as soon as
the algorithm is built, as in RLlib) and after every epoch until the next ``train()``.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections import defaultdict
from typing import Any, ClassVar

import gymnasium as gym
import yaml

from rlchain.config.errors import ConfigError
from rlchain.envs.factory import build_env
from rlchain.policy.play import play
from rlchain.rllib import envs, evaluation_runners, module_network, multi_agent, translate
from rlchain.rllib.callbacks.callbacks import EpisodeEvents, MetricsLogger, RLlibCallback, nested, steps_episodes
from rlchain.rllib.callbacks.user import EventFunctions, callback_objects
from rlchain.rllib.checkpoint_files import (
    CHECKPOINT_FILE,
    CONFIG_FILE,
    RLCHAIN_CONFIG_FILE,
    SavedCheckpoint,
    checkpoint_file,
    checkpoint_path,
    json_data,
    read_text,
    stored_config,
)
from rlchain.rllib.core import DEFAULT_MODULE_ID
from rlchain.rllib.env_runner_group import EnvRunnerGroup
from rlchain.rllib.episode_window import IterationEpisodes, episode_metrics
from rlchain.rllib.evaluation_env import evaluation_explore, evaluation_params
from rlchain.rllib.module import OldPolicy, RLModuleView
from rlchain.rllib.module_checkpoint import write_module_folders
from rlchain.rllib.replay_buffer import LocalReplayBuffer
from rlchain.rllib.results import (
    deep_update,
    last_minibatch_by_policy,
    learner_inputs,
    learner_results,
    scheduled_results,
    train_result,
)
from rlchain.rllib.schedules import Schedules
from rlchain.rllib.stepper import ParkingStepper
from rlchain.runner import Runner

ALGORITHMS: dict[str, type] = {}
"""The face's Algorithm classes by RLlib name (each subclass with an ``algo_name`` registers itself)."""


class Algorithm:
    """One RLlib algorithm (PPO, DQN) trained by rlchain; see the module docstring."""

    algo_name: ClassVar[str] = ""
    action_spaces: ClassVar[tuple[type, ...]] = (gym.spaces.Box, gym.spaces.Discrete)
    """The action spaces rlchain's algorithm of this name takes."""

    @staticmethod
    def translate(config: Any, env_name: str, obs_space: Any, continuous: bool, run: dict[str, Any]
                  ) -> dict[str, Any]:
        """The rlchain config (``{'params': ...}``) that trains ``config`` on env ``env_name`` (each algorithm's)."""
        return translate.ppo_config(config, env_name, continuous, run, obs_space)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "algo_name" in cls.__dict__ and cls.algo_name:  # the face's own (a user's subclass keeps its parent's)
            ALGORITHMS[cls.algo_name] = cls

    def __init__(self, config: Any = None, env: Any = None, logger_creator: Any = None, **kwargs: Any) -> None:
        if config is None or not hasattr(config, "_settings"):
            raise ConfigError("Algorithm", "config", "build it from a config: PPOConfig()...build_algo()")
        if env is not None:
            config = config.copy().environment(env)
        self.config = config
        config.validate()
        config.freeze()
        settings = config._settings
        if settings.get("env") is None:
            raise ConfigError(type(config).__name__, "env", "no env: .environment('CartPole-v1') or an env class")
        self.iteration = 0
        self._counters: defaultdict[str, int] = defaultdict(int)  # RLlib's counters, which its examples use too
        self._time_total = 0.0
        self._schedules = Schedules(config)  # lr / entropy_coeff given as [[timestep, value], ...]
        self.metrics = MetricsLogger()
        self._env_runner_metrics = MetricsLogger()
        self.callbacks = callback_objects(settings.get("callbacks_class"))
        functions = {k: settings[k] for k in ("on_algorithm_init", "on_train_result", "on_episode_start",
                                              "on_episode_step", "on_episode_end", "on_evaluate_start",
                                              "on_evaluate_end")
                     if settings.get(k) is not None}
        if functions:
            self.callbacks.append(EventFunctions(functions))
        runners = int(settings.get("num_env_runners") or 0)
        per_runner = max(1, int(settings.get("num_envs_per_env_runner") or 1))
        self._make, self._label = envs.env_maker(settings["env"], settings.get("env_config") or {}, runners,
                                                 per_runner)
        probe = self._make(0)
        try:
            self.observation_space, self.action_space = probe.observation_space, probe.action_space
            self._multi = multi_agent.MultiAgentRun(config, probe) if multi_agent.is_multi_agent(probe) else None
        finally:
            probe.close()
        if self._multi is None and settings.get("policies") is not None:
            raise ConfigError(type(config).__name__, "policies", f"{self._label} is not a MultiAgentEnv: policies "
                                                                 f"need one (leave .multi_agent() unset)")
        gpu = (settings.get("num_gpus_per_learner") or 0) > 0 or (settings.get("num_gpus") or 0) > 0
        run = {"name": _run_name(config.algo_name, settings["env"]), "device": "cuda:0" if gpu else "cpu",
               "print_stats": False}
        if self._multi is not None:
            self._env_name, self.rlchain_config = self._multi.rlchain_config(
                config, self._make, run, lambda pid, obs, act: module_network.policy_network(config, pid, obs, act))
        else:
            self.rlchain_config = self._single_agent_config(config, run)
        self.runner = Runner().load(self.rlchain_config, source=type(config).__name__)  # errors name PPOConfig
        self.env_runner_group = EnvRunnerGroup(self)
        self.env_runner = self.env_runner_group.local_env_runner
        extra = []
        self._episode_events: EpisodeEvents | None = None  # the callbacks' running episodes (make_env drops them)
        if any(getattr(type(cb), event) is not getattr(RLlibCallback, event)
               for event in ("on_episode_start", "on_episode_step", "on_episode_end")
               for cb in self.callbacks if not isinstance(cb, EventFunctions)) \
                or any(name.startswith("on_episode_") for name in functions):
            self._episode_events = EpisodeEvents(self.callbacks, self._env_runner_metrics, self.env_runner)
            extra.append(self._episode_events)
        # RLlib's episode results count the episodes of each train() only (see episode_window)
        self._episodes = IterationEpisodes(runners, per_runner,
                                           int(settings.get("metrics_num_episodes_for_smoothing") or 100))
        if self._episodes.per_runner and self._multi is None and config.algo_name == "PPO":
            extra.append(self._episodes)  # PPO's rollout steps the envs here: each episode's runner is known
        else:
            self._episodes.per_runner = False  # the episodes the tracker finished, all runners together
        self._stepper = ParkingStepper(self.runner, seed=settings.get("seed"))
        self._stepper._extra = extra
        self._stepper._run = self._run_thread
        self._stepper.start()
        self._stopped = False
        for cb in self.callbacks:
            cb.on_algorithm_init(algorithm=self, metrics_logger=self.metrics)

    def _single_agent_config(self, config: Any, run: dict[str, Any]) -> dict[str, Any]:
        """The rlchain config of a single-agent env (its env registered when it is not a plain gymnasium id)."""
        settings = config._settings
        plain_id = isinstance(settings["env"], str) and not settings.get("env_config") \
            and envs.tune_registered(settings["env"]) is None and not getattr(self._make, "flattened", False)
        env_name = settings["env"] if plain_id else envs.register(self._make, self._label)
        self._env_name = env_name
        continuous = isinstance(self.action_space, gym.spaces.Box)
        allowed = self.action_spaces
        if not isinstance(self.action_space, allowed):
            raise ConfigError(type(config).__name__, "env", f"{type(self.action_space).__name__} actions are not "
                              f"mapped by the face for {config.algo_name} "
                              f"({' or '.join(a.__name__ for a in allowed)})")
        start = self._schedules.starting_config(config) if self._schedules else config
        out = self.translate(start, env_name, self.observation_space, continuous, run)
        env_settings = out["params"]["config"]
        if any(steps_episodes(cb) for cb in self.callbacks) and env_settings.get("vecenv_type", "auto") == "auto":
            env_settings["vecenv_type"] = "sync"  # RLlib's runners step a SyncVectorEnv: on_episode_step's env.envs
        vecenv = vector_env_type(settings.get("gym_env_vectorize_mode"), env_settings.get("vecenv_type", "auto"))
        if vecenv is not None:
            env_settings["vecenv_type"] = vecenv
        if config.algo_name == "PPO":  # a user's RLModule as the network
            module_network.apply_spec(config, out, self.observation_space, self.action_space)
        return out

    def _run_thread(self) -> None:
        stepper = self._stepper
        try:
            result = self.runner.train(checkpoint=stepper.checkpoint, seed=stepper.seed,
                                       callbacks=[stepper, *stepper._extra])
        except BaseException as exc:  # handed to the caller's thread
            stepper._events.put(("error", exc))
            return
        stepper._events.put(("end", result))

    # ----- training ------------------------------------------------------------------------------------
    def train(self) -> dict[str, Any]:
        """One training iteration (one rlchain epoch of about ``train_batch_size`` env steps); RLlib's result."""
        self._check_running()
        if self._schedules:  # RLlib's value at the env steps sampled so far, for this train()'s update
            ctx = self._stepper.context
            ctx.set_params(**self._schedules.at(int(ctx.state.frames)))
        report = self._stepper.next_epoch()
        if report is None:
            raise RuntimeError("the rlchain run has ended (see its log); build a new algorithm")
        self.iteration += 1
        self._time_total += report.seconds
        result = self._result(report)
        interval = self.config._settings.get("evaluation_interval")
        if interval and self.iteration % int(interval) == 0:
            result["evaluation"] = self.evaluate()
        for cb in self.callbacks:
            cb.on_train_result(algorithm=self, metrics_logger=self.metrics, result=result)
        custom = self.metrics.reduce()
        if custom:
            deep_update(result, nested(custom))
        self._write_custom({**custom, **{f"env_runners/{k}": v for k, v in result.get("_episode_custom", {}).items()}})
        result.pop("_episode_custom", None)
        self.metrics.remember(result)
        return result

    step = train  # Tune's Trainable name

    def _result(self, report: Any) -> dict[str, Any]:
        ctx = self._stepper.context
        tracker = ctx.episode_tracker
        cfg = self.rlchain_config["params"]["config"]
        agent = getattr(ctx.algorithm, "agent", None)
        learner = self.learner_results(learner_inputs(report.stats, agent, int(report.frames)), cfg)
        if self._schedules:  # RLlib reports the value after its scheduler's step: the next train()'s
            learner.update(scheduled_results(self._schedules.at(int(ctx.state.frames))))
        return train_result(report, cfg, iteration=self.iteration, time_total=self._time_total,
                            games=int(getattr(tracker, "games", 0) or 0),
                            episodes=None if self._multi is not None else self._episodes.take(tracker),
                            episode_custom=self._env_runner_metrics.reduce(), learner=learner, multi=self._multi,
                            last_by_policy=last_minibatch_by_policy(agent) if self._multi is not None else None)

    @staticmethod
    def learner_results(stats: dict[str, Any], cfg: dict[str, Any]) -> dict[str, Any]:
        """RLlib's ``learners/<module>`` results from rlchain's epoch statistics (each algorithm's names)."""
        return learner_results(stats)

    def _write_custom(self, values: dict[str, Any]) -> None:
        ctx = self._stepper.context
        writer = getattr(ctx, "writer", None) if ctx is not None else None
        if writer is None or not values:
            return
        frames = int(ctx.state.frames)
        for key, value in values.items():
            if isinstance(value, (int, float)) and not isinstance(value, bool):  # items and series stay in the result
                writer.add_scalar(f"custom/{key}", value, frames)

    # ----- evaluation -----------------------------------------------------------------------------------
    def evaluate(self) -> dict[str, Any]:
        """``evaluation_duration`` episodes (or env steps, ``evaluation_duration_unit='timesteps'``) of the current
        policy on a fresh env, sampled unless ``evaluation_config`` (or the config) sets ``explore=False``, as
        RLlib's; RLlib's evaluation results (``{'env_runners': {'episode_return_mean', ...}}``)."""
        self._check_running()
        s = self.config._settings
        for cb in self.callbacks:
            cb.on_evaluate_start(algorithm=self, metrics_logger=self.metrics)
        if s.get("custom_evaluation_function") is not None:  # RLlib's call: fn(algo, algo.eval_env_runner_group)
            out = evaluation_runners.evaluate_custom(self, s["custom_evaluation_function"])
            for cb in self.callbacks:
                cb.on_evaluate_end(algorithm=self, metrics_logger=self.metrics, evaluation_metrics=out)
            return out
        duration = s.get("evaluation_duration") or 10
        by_steps = s.get("evaluation_duration_unit") == "timesteps"
        if duration == "auto":
            duration, by_steps = 10, False
        explore = evaluation_explore(s)
        if self._multi is not None:  # every policy plays its agents (by episodes: a multi-agent step is no unit)
            out = self._multi.evaluate(self.runner.params, self._stepper.context.model,
                                       10 if by_steps else int(duration), deterministic=not explore)
            for cb in self.callbacks:
                cb.on_evaluate_end(algorithm=self, metrics_logger=self.metrics, evaluation_metrics=out)
            return out
        self.get_module()  # checks the module id and that the algorithm runs
        seed = s.get("seed")
        if getattr(self, "_eval_params", None) is None:  # the run's env, or evaluation_config's
            self._eval_params = evaluation_params(s, self.runner.params)
        env = build_env(self._eval_params, 1, None if seed is None else int(seed) + 10_000)
        try:  # the play loop steps the env, as for any rlchain evaluation
            result = play(self._stepper.context.model, env, None if by_steps else int(duration),
                          deterministic=not explore, steps=int(duration) if by_steps else None)
        finally:
            env.close()
        steps = int(duration) if by_steps else round(result.mean_length * result.games)
        games = episode_metrics([(r, result.mean_length) for r in result.rewards])  # play reports the mean length
        out = {"env_runners": {**games, "num_env_steps_sampled": steps},
               "episode_reward_mean": games["episode_return_mean"]}
        for cb in self.callbacks:
            cb.on_evaluate_end(algorithm=self, metrics_logger=self.metrics, evaluation_metrics=out)
        return out

    @property
    def eval_env_runner_group(self) -> evaluation_runners.EvaluationRunnerGroup:
        """The evaluation env runners a ``custom_evaluation_function`` gets (:mod:`.evaluation_runners`)."""
        return evaluation_runners.group(self)

    # ----- the policy ------------------------------------------------------------------------------------
    @property
    def training_iteration(self) -> int:
        """The ``train()`` calls so far (Ray Tune's Trainable attribute, which RLlib's callbacks read)."""
        return self.iteration

    @property
    def local_replay_buffer(self) -> LocalReplayBuffer | None:
        """DQN's / SAC's replay buffer as RLlib's (``get_state()``: :mod:`rlchain.rllib.replay_buffer`); None for
        the algorithms without one (PPO, APPO, IMPALA), as in RLlib."""
        self._check_running()
        ctx = self._stepper.context
        buffer = getattr(ctx.algorithm, "buffer", None) if ctx is not None else None
        if buffer is None:
            return None
        updates = int(getattr(getattr(ctx.algorithm, "agent", None), "updates", 0) or 0)
        batch = int(self.rlchain_config["params"]["config"].get("batch_size") or 0)
        return LocalReplayBuffer(buffer, self.observation_space, self.action_space, int(ctx.state.frames),
                                 updates * batch)

    def get_module(self, module_id: str = DEFAULT_MODULE_ID) -> RLModuleView:
        """The trained policy as RLlib's RLModule (``forward_inference({'obs': batch})``)."""
        self._check_running()
        model = self._stepper.context.model
        if self._multi is not None:
            if module_id == DEFAULT_MODULE_ID and DEFAULT_MODULE_ID not in model and len(model) == 1:
                module_id = next(iter(model))
            if module_id not in model:
                raise KeyError(f"module '{module_id}': the policies are {', '.join(model)}")
            obs_space, act_space = self._multi.spaces[module_id]
            return RLModuleView(model[module_id], obs_space, act_space)
        if module_id != DEFAULT_MODULE_ID:
            raise KeyError(f"module '{module_id}': the face trains one module, '{DEFAULT_MODULE_ID}'")
        return RLModuleView(model, self.observation_space, self.action_space)

    def compute_single_action(self, observation: Any = None, state: Any = None, *, explore: bool | None = None,
                              policy_id: str = DEFAULT_MODULE_ID, full_fetch: bool = False, **kwargs: Any) -> Any:
        """RLlib's older single-observation call: the action (sampled unless ``explore=False``)."""
        action = self.get_module(policy_id).act(observation, True if explore is None else bool(explore))
        return (action, [], {}) if full_fetch or state is not None else action

    def get_policy(self, policy_id: str = DEFAULT_MODULE_ID) -> OldPolicy:
        """The older Policy object: its ``compute_single_action`` returns (action, states, extras)."""
        return OldPolicy(self.get_module(policy_id))

    # ----- checkpoints ------------------------------------------------------------------------------------
    def save_to_path(self, path: str | None = None, **kwargs: Any) -> str:
        """Write a checkpoint folder: rlchain's checkpoint (exact resume state), the RLlib config as JSON data
        and the rlchain YAML it trains. Returns the folder."""
        self._check_running()
        path = os.fspath(path) if path is not None else tempfile.mkdtemp(prefix="rlchain_rllib_")
        os.makedirs(path, exist_ok=True)
        self._stepper.save(os.path.join(path, CHECKPOINT_FILE))
        with open(os.path.join(path, CONFIG_FILE), "w") as f:
            json.dump({"algo": self.config.algo_name, "iteration": self.iteration,
                       "config": json_data(self.config.to_dict())}, f, indent=1)
        with open(os.path.join(path, RLCHAIN_CONFIG_FILE), "w") as f:
            yaml.safe_dump(self.rlchain_config, f, sort_keys=False)
        model = self._stepper.context.model
        write_module_folders(path, list(model) if self._multi is not None else [DEFAULT_MODULE_ID])
        return path

    def save(self, checkpoint_dir: str | None = None, **kwargs: Any) -> SavedCheckpoint:
        """RLlib's older save: an object whose ``checkpoint.path`` is the folder."""
        return SavedCheckpoint(self.save_to_path(checkpoint_dir))

    def restore_from_path(self, path: str, **kwargs: Any) -> None:
        """Load a checkpoint folder written by :meth:`save_to_path` (or an rlchain ``.pth``) into this algorithm:
        weights, optimizer, counters. RLlib's own (pickled) checkpoints are refused."""
        self._check_running()
        path = checkpoint_path(path)  # also Tune's Checkpoint or what save() returned
        self._stepper.load(checkpoint_file(path))
        self._episodes.sync(self._stepper.context.episode_tracker)
        if os.path.isdir(path):
            self.iteration = stored_config(path).get("iteration", self.iteration)
        frames = int(self._stepper.context.state.frames)
        self.metrics.remember({"env_runners": {"num_env_steps_sampled_lifetime": frames}, "training_iteration":
                               self.iteration, "num_env_steps_sampled_lifetime": frames})
        for cb in self.callbacks:
            cb.on_checkpoint_loaded(algorithm=self)

    restore = restore_from_path

    @classmethod
    def from_checkpoint(cls, path: Any, config: Any = None, **kwargs: Any) -> Algorithm:
        """A new algorithm from a :meth:`save_to_path` folder: ``config`` (RLlib's ``from_checkpoint(path,
        config=...)``), else the folder's config read as JSON data, built, then the checkpoint restored. An env or
        an RLModule given as a class is not in the JSON: pass ``config``."""
        path = os.fspath(getattr(path, "path", path))
        checkpoint_file(path)  # refuses RLlib's own checkpoints first
        if config is not None:
            algo = config.build_algo()
            algo.restore_from_path(path)
            return algo
        stored = stored_config(path)
        name = stored.get("algo", "PPO")
        if name not in ALGORITHMS:
            raise ConfigError(path, "algo", f"'{name}' is not an algorithm of the face "
                                            f"({', '.join(ALGORITHMS) or 'import rlchain.rllib.algorithms'})")
        config = ALGORITHMS[name].get_default_config()
        data = {k: v for k, v in stored.get("config", {}).items() if v is not _MISSING}
        if module_network.NAME_PREFIX in read_text(os.path.join(path, RLCHAIN_CONFIG_FILE)):
            raise ConfigError(path, "rl_module_spec", "the checkpoint trained an RLModule class, which is not in the "
                                                      "JSON: build your config with its RLModuleSpec and call "
                                                      "algo.restore_from_path(path) or from_checkpoint(path, "
                                                      "config=config)")
        env = data.get("env")
        if not isinstance(env, str):
            raise ConfigError(path, "env", "the checkpoint's env is not a name: pass your config with its env, "
                                           "from_checkpoint(path, config=config)")
        config.update_from_dict({k: v for k, v in data.items() if k in config})
        algo = config.build_algo()
        algo.restore_from_path(path)
        return algo

    def stop(self) -> None:
        """End the run (rlchain writes its last checkpoint and closes the envs)."""
        if not self._stopped:
            self._stopped = True
            self._stepper.shutdown()
            evaluation_runners.close(self)

    cleanup = stop  # Tune's Trainable name (RLlib's Algorithm.cleanup releases the runners)

    def _check_running(self) -> None:
        if getattr(self, "_stopped", False):
            raise RuntimeError("this algorithm was stopped; build a new one")

    def __del__(self) -> None:
        try:
            self.stop()
        except Exception:
            pass


_MISSING = object()


def vector_env_type(mode: Any, current: Any) -> str | None:
    """rlchain's ``vecenv_type`` for RLlib's ``gym_env_vectorize_mode``: ASYNC (gymnasium's ``AsyncVectorEnv``, a
    process per env) is rlchain's ``async`` where the envs step in this process; None leaves ``current``."""
    if str(getattr(mode, "value", mode)).lower() == "async" and current in ("auto", "sync", None):
        return "async"
    return None


def _run_name(algo: str, env: Any) -> str:
    import re
    base = env if isinstance(env, str) else getattr(env, "__name__", "env")
    base = re.sub(r"-v\d+$", "", base.rsplit("/", 1)[-1])
    return f"rllib_{algo.lower()}_" + (re.sub(r"[^a-z0-9]+", "_", base.lower()).strip("_") or "env")
