"""The SB3-shaped front of rlchain: ``PPO("MlpPolicy", env).learn(n)``, ``predict``, ``save`` / ``load``.

A model holds an rl_games-style config (``model.config``, ``model.save_config(path)``: the YAML that
``rlchain train`` runs the same way) and a policy network built from it. ``learn`` trains with rlchain's
own Runner and loop (a run folder under ``tensorboard_log`` or ``runs/``, as ``rlchain train`` writes) and
copies the trained weights back; a later ``learn`` resumes that run from its last checkpoint (optimizer,
normalizers and counters included) and trains ``total_timesteps`` more frames.
"""

from __future__ import annotations

import copy
import dataclasses
import os
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import torch
import yaml

from rlchain.config.algo_keys import config_class_of
from rlchain.config.errors import ConfigError
from rlchain.envs.backends.sb3_vecenv import vec_normalize_of
from rlchain.envs.obs_dict import as_obs_dict
from rlchain.models.build import build_env
from rlchain.networks.user_classes import remember, resolve
from rlchain.policy.load import load_policy
from rlchain.runner import Runner
from rlchain.sb3 import files
from rlchain.sb3.callbacks import SB3Callbacks, is_sb3_callback
from rlchain.sb3.defaults import CHOICES, SB3_NUM_ENVS
from rlchain.sb3.envs import EnvSource, env_source, sb3_vec_env
from rlchain.sb3.her import is_her
from rlchain.sb3.keys import build_config, multi_input_block, positive_count, rlchain_num_envs
from rlchain.sb3.logger import SB3Logger
from rlchain.sb3.model_load import Spaces, load_model, model_file
from rlchain.sb3.model_zip import (
    write_model_zip,
)
from rlchain.sb3.policy import TORCH_ACTIVATIONS, SB3Policy, eval_actions
from rlchain.sb3.policy_block import needs_sb3_network, sb3_network_block, stored_policy_kwargs
from rlchain.sb3.replay import ReplayBufferView, ReplayCallback, load_replay, save_replay
from rlchain.sb3.schedules import ScheduleCallback, split_schedules
from rlchain.sb3.zip_format import write_sb3_archive
from rlchain.training.events import Callback

POLICIES = {"MlpPolicy": None, "MultiInputPolicy": "multi_input", "CnnPolicy": "sb3_policy"}
"""SB3's policy names -> the rlchain network they map to (None: the algorithm's default network). MultiInputPolicy:
Dict observations, an encoder per key (docs/robot_learning.md); CnnPolicy: SB3's NatureCNN
(:mod:`rlchain.networks.sb3_policy`, as a policy class or a ``features_extractor_class``)."""

PER_KEY_NETWORKS = ("multi_input", "sb3_policy")  # networks that take Dict observations per key


class _Bridge(Callback):
    """Hands the model's weights to the run when they changed since the last run; while the run goes,
    ``model.policy`` is the policy being trained (callbacks' ``predict`` and ``save`` see the live weights); when
    it ends the trained weights are copied back into the model's own policy."""

    def __init__(self, model: BaseModel) -> None:
        self.model = model
        self._own: torch.nn.Module | None = None

    def on_train_start(self, ctx: Any) -> None:
        own = self.model.policy
        if self.model._weights_changed:
            ctx.model.load_state_dict(own.net.state_dict())
        self._own, self.model.policy = own, SB3Policy(ctx.model, own.algo, own.observation_space, own.action_space,
                                                      own.network)

    def on_train_end(self, ctx: Any, result: Any) -> None:
        if self._own is not None:
            self._own.net.load_state_dict(copy.deepcopy(ctx.model.state_dict()))
        self.model._weights_changed = False
        self.close()

    def close(self) -> None:
        if self._own is not None:
            self.model.policy, self._own = self._own, None


class BaseModel:
    """What PPO, SAC and DQN share; see the module docstring."""

    algo: ClassVar[str] = ""

    def __init__(self, policy: str, env: Any, *, n_envs: int | None = None, seed: int | None = None,
                 device: str = "auto", verbose: int = 1, tensorboard_log: str | None = None,
                 policy_kwargs: dict[str, Any] | None = None, **hyperparameters: Any) -> None:
        source = f"rlchain.{self.algo.upper()}"
        if isinstance(policy, str) and policy not in POLICIES and "." in policy:  # a stored policy class's name
            policy = resolve(policy, "policy")
        if isinstance(policy, str) and policy not in POLICIES:
            raise ConfigError(source, "policy", f"'{policy}' is not supported (choices: {', '.join(POLICIES)}, or "
                                                f"an ActorCriticPolicy subclass); other networks: the network "
                                                f"block of an rlchain YAML")
        self.policy_name = policy if isinstance(policy, str) else remember(policy)
        self.policy_class = policy  # a name of POLICIES, or a policy class
        self.env_source: EnvSource | None = None if env is None else env_source(env, self.algo)
        self._env_arg = env  # the env argument as given: get_env() builds SB3's VecEnv of it
        self._vec_env: Any = None
        fixed = None if self.env_source is None else self.env_source.num_envs
        if fixed is not None and n_envs is not None and n_envs != fixed:
            raise ConfigError(source, "n_envs", f"{n_envs}, but {self.env_source.label} is {fixed} env(s)")
        self.defaults = hyperparameters.get("defaults", "sb3")  # kept in hyperparameters: save() keeps it
        if self.defaults not in CHOICES:
            raise ConfigError(source, "defaults", f"expected one of {', '.join(CHOICES)}, got {self.defaults!r}")
        default_envs = SB3_NUM_ENVS[self.algo] if self.defaults == "sb3" else rlchain_num_envs(self.algo)
        self.n_envs = fixed or n_envs or default_envs
        self.seed = seed
        self.device = ("cuda:0" if torch.cuda.is_available() else "cpu") if device == "auto" else device
        self.verbose = verbose
        self.tensorboard_log = tensorboard_log
        self.policy_kwargs = dict(policy_kwargs or {})
        try:
            given, self._schedules = split_schedules(self.algo, hyperparameters)
        except ValueError as exc:
            key, _, message = str(exc).partition(": ")
            raise ConfigError(source, key, message) from None
        if is_her(given.get("replay_buffer_class")):
            given["replay_buffer_class"] = "HerReplayBuffer"  # kept by name: the model's arguments stay data
        self.hyperparameters = given  # data only: a schedule's value at progress 1 (the callable: _schedules)
        self.num_timesteps = 0
        self._checkpoint: str | None = None  # the last run's last checkpoint: a later learn resumes it
        self._weights_changed = False
        self._spaces: Spaces | None = None
        self._loaded_config: dict[str, Any] | None = None  # load() without an env: the saved config
        self.policy: SB3Policy | None = None
        if self.env_source is not None:
            self._spaces = self._read_spaces()
            self.policy = self._build_policy()
        self.replay_buffer: ReplayBufferView | None = None
        if self.algo != "ppo" and self.env_source is not None:
            self.replay_buffer = ReplayBufferView(self.config["params"]["config"]["replay_buffer_size"])

    # ----- the config -------------------------------------------------------------------------------
    def _config(self, total_timesteps: int | None = None) -> dict[str, Any]:
        if self.env_source is None:
            raise ValueError(f"rlchain.{self.algo.upper()}: no env; pass env= to load() (or to the constructor)")
        continuous = self._spaces is not None and not hasattr(self._spaces.action_space, "n")
        run = {"device": self.device, "print_stats": self.verbose > 0}
        if self.tensorboard_log:
            run["train_dir"] = self.tensorboard_log
        family = "a2c_continuous" if self.algo == "ppo" and continuous else \
            {"ppo": "a2c_discrete", "sac": "sac", "dqn": "dqn"}[self.algo]
        keys = [f.name for f in dataclasses.fields(config_class_of(family))]
        given = {k: v for k, v in self.hyperparameters.items() if k != "defaults"}
        own = needs_sb3_network(self.algo, self.policy_class, self.policy_kwargs)
        config = build_config(self.algo, self.env_source.env_name, self.n_envs, continuous, given,
                              keys, {} if own else self.policy_kwargs, total_timesteps, self.seed, run, self.defaults)
        if own:
            try:
                config["params"]["network"] = sb3_network_block(self.algo, self.policy_class, self.policy_kwargs)
            except ValueError as exc:
                key, _, message = str(exc).partition(": ")
                raise ConfigError(f"rlchain.{self.algo.upper()}", key, message) from None
        elif POLICIES[self.policy_name] is not None and "replay" not in config["params"]["config"]:
            # (hindsight replay reads a goal Dict flattened with its parts named: the algorithm's own network)
            multi_input_block(self.algo, config["params"], POLICIES[self.policy_name])
        return config

    @property
    def config(self) -> dict[str, Any]:
        """The rl_games-style config this model trains with (``{'params': ...}``)."""
        if self.env_source is None and self._loaded_config is not None:
            return copy.deepcopy(self._loaded_config)
        return self._config()

    def save_config(self, path: str, total_timesteps: int | None = None) -> str:
        """Write :attr:`config` as YAML with ``max_frames`` = ``total_timesteps`` (default: the last ``learn``'s
        total), so ``rlchain train <path>`` runs the same training and stops (for an env object or callable,
        register the env under its name first)."""
        total = total_timesteps if total_timesteps is not None else getattr(self, "_total_timesteps", None)
        if total is None:
            raise ValueError(f"rlchain.{self.algo.upper()}.save_config: total_timesteps: pass the frames to train "
                             f"(the YAML's max_frames), or learn first")
        total = positive_count(f"rlchain.{self.algo.upper()}.save_config", "total_timesteps", total)
        with open(path, "w") as f:
            yaml.safe_dump(self._config(total), f, sort_keys=False)
        return path

    def _runner(self, total_timesteps: int | None = None) -> Runner:
        return Runner().load(self._config(total_timesteps))

    def _read_spaces(self) -> Spaces:
        runner = self._runner()  # checks every argument now, as SB3 fails in the constructor
        params = runner.params
        env = build_env(params, self.n_envs if self.env_source.vec_env is not None else 1, 0)
        try:
            return Spaces(env.observation_space, env.action_space)
        finally:
            env.close()

    def _build_policy(self, config: dict[str, Any] | None = None) -> SB3Policy:
        """``model.policy``: the network of ``config`` (default: this model's, its first weights from ``seed``; a
        loaded file's keeps them unseeded) built on the CPU by :func:`~rlchain.policy.load.load_policy` for the
        model's spaces, in eval mode, with SB3's names, predict and save (:mod:`rlchain.sb3.policy`)."""
        new = config is None
        config = self.config if new else config
        params = self._runner().params if self.env_source is not None else Runner().load(copy.deepcopy(config)).params
        if new and self.seed is not None:
            torch.manual_seed(self.seed)
        net = load_policy(params, device=torch.device("cpu"), env=self._spaces).model
        return SB3Policy(net, self.algo, self._spaces.observation_space, self._spaces.action_space,
                         config["params"]["network"])

    # ----- SB3's attributes ------------------------------------------------------------------------------
    @property
    def learning_rate(self) -> Any:
        """The learning rate as given (a number or ``fn(progress_remaining)``), else the one the config trains
        with (SAC: the actor's)."""
        if "learning_rate" in self._schedules:
            return self._schedules["learning_rate"]
        if "learning_rate" in self.hyperparameters:
            return self.hyperparameters["learning_rate"]
        cfg = self.config["params"]["config"]
        return cfg.get("learning_rate", cfg.get("actor_lr"))

    @property
    def gamma(self) -> float:
        """The discount factor the config trains with."""
        return float(self.config["params"]["config"]["gamma"])

    @property
    def env(self) -> Any:
        """SB3's ``model.env``: the training env as an SB3 ``VecEnv`` (:meth:`get_env`)."""
        return self.get_env()

    @property
    def observation_space(self) -> Any:
        """The observation space of the env the model trains on (None before it has one)."""
        return None if self._spaces is None else self._spaces.observation_space

    @property
    def action_space(self) -> Any:
        """The action space of the env the model trains on (None before it has one)."""
        return None if self._spaces is None else self._spaces.action_space

    @property
    def actor(self) -> Any:
        """SAC: SB3's ``model.actor`` (``model.policy.actor``)."""
        return self.policy.actor

    # ----- training -----------------------------------------------------------------------------------
    def learn(self, total_timesteps: int, callback: Any = None, progress_bar: bool = False,
              reset_num_timesteps: bool = True, log_interval: int | None = None,
              tb_log_name: str | None = None) -> BaseModel:
        """Train for ``total_timesteps`` env frames (rounded up to whole epochs) on rlchain's loop.

        ``callback``: Stable-Baselines3 callbacks (``BaseCallback`` subclasses, ``EvalCallback``, ``CallbackList``,
        ..., run as SB3 runs them: :mod:`rlchain.sb3.callbacks`), an rlchain
        :class:`~rlchain.training.events.Callback`, a function ``fn(ctx, stats, episodes)`` called after every
        epoch, or a list of them. ``progress_bar=True`` shows rlchain's live status line.
        ``reset_num_timesteps=True`` (SB3's default) starts a new run from the current weights with the count at 0;
        False resumes the last run from its checkpoint (optimizer, normalizers and counters) and trains
        ``total_timesteps`` more. ``log_interval``: how often what SB3 callbacks ``logger.record`` is dumped
        (SB3's: PPO every that many iterations, default 1; SAC / DQN every that many episodes, default 4);
        rlchain's tags: every epoch.
        """
        if self.policy is None:
            raise ValueError(f"rlchain.{self.algo.upper()}: no env; pass env= to load() to train")
        total = positive_count(f"rlchain.{self.algo.upper()}.learn", "total_timesteps", total_timesteps)
        given = callback if isinstance(callback, (list, tuple)) else ([] if callback is None else [callback])
        sb3 = [cb for cb in given if is_sb3_callback(cb)]
        callbacks = [cb for cb in given if not is_sb3_callback(cb)]
        if reset_num_timesteps and self._checkpoint is not None:
            self._checkpoint = None  # a new run from the model's weights, as SB3 keeps its policy
            self._weights_changed = True
        if reset_num_timesteps:
            self.num_timesteps = 0
        overrides = []
        if progress_bar:
            overrides.append("params.config.progress.live=True")
        if tb_log_name:
            overrides.append(f"params.config.name={tb_log_name}")
        runner = Runner().load(self._config(self.num_timesteps + total), overrides)
        if self.verbose > 0 and self._checkpoint is None:
            self._say_config(total)
        if sb3:
            learn_locals = {"total_timesteps": self.num_timesteps + total, "callback": callback,
                            "log_interval": log_interval, "tb_log_name": tb_log_name,
                            "reset_num_timesteps": reset_num_timesteps, "progress_bar": progress_bar}
            callbacks.append(SB3Callbacks(self, sb3, learn_locals))
        self._total_timesteps = self.num_timesteps + total
        if self.replay_buffer is not None:
            callbacks.append(ReplayCallback(self))
        if self._schedules:
            callbacks.append(ScheduleCallback(self.algo, self._schedules, self.num_timesteps, total))
        result = runner.train(checkpoint=self._checkpoint, seed=self.seed, callbacks=[_Bridge(self), *callbacks])
        self.num_timesteps = int(result.frames)
        self.run_dir = result.run_dir
        self.logger.dir = result.run_dir
        last = os.path.join(result.run_dir, "nn", f"last_{runner.params.config.name}.pth")
        self._checkpoint = last if os.path.isfile(last) else None
        self.result = result
        return self

    def _say_config(self, total: int) -> None:
        """verbose 1: one line saying what runs (as SB3 says its device); verbose 2: the whole YAML too."""
        cfg = self._config(total)["params"]["config"]
        print(f"rlchain: {type(self).__name__} on {self.env_source.label}, {cfg['num_actors']} env(s), device "
              f"{self.device} (model.save_config('cfg.yaml') writes the YAML it runs)", flush=True)
        if self.verbose > 1:
            print(yaml.safe_dump(self._config(total), sort_keys=False), flush=True)

    @property
    def logger(self) -> SB3Logger:
        """SB3's ``logger`` for callbacks: ``record`` / ``dump`` go to the run's log writers."""
        if getattr(self, "_logger", None) is None:
            self._logger = SB3Logger()
        return self._logger

    def export_onnx(self, path: str) -> str:
        """PPO: the deterministic policy as an ONNX graph (rlchain's exporter, checked with onnx); returns the path."""
        if self.algo != "ppo":
            raise ValueError(f"rlchain.{self.algo.upper()}.export_onnx: ONNX export is for PPO's actor-critic")
        return self.policy.export_onnx(os.fspath(path))

    def save_replay_buffer(self, path: str) -> str:
        """Write the replay buffer's contents (SAC, DQN; see :mod:`rlchain.sb3.replay`); returns the path."""
        if self.replay_buffer is None:
            raise ValueError(f"rlchain.{self.algo.upper()}: no replay buffer (an on-policy model, or no env)")
        return save_replay(self.replay_buffer, path)

    def load_replay_buffer(self, path: str) -> None:
        """Read a replay buffer :meth:`save_replay_buffer` wrote; the next ``learn`` starts with it."""
        capacity = self.config["params"]["config"]["replay_buffer_size"]
        self.replay_buffer = load_replay(path, capacity)

    def dump_logs(self) -> None:
        """Write what callbacks recorded (SB3's ``dump_logs``)."""
        self.logger.dump(self.num_timesteps)

    # ----- acting -------------------------------------------------------------------------------------
    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        """``(actions, state)`` for one observation or a batch of them, as SB3 returns them (``state`` is
        None: MlpPolicy has no memory)."""
        if self.policy is None:
            raise ValueError(f"rlchain.{self.algo.upper()}: no policy yet; construct with an env or load()")
        space = self._spaces.observation_space
        if isinstance(space, gym.spaces.Dict) and self.config["params"]["network"].get("name") in PER_KEY_NETWORKS:
            return self._predict_dict(observation, space, deterministic)
        return self.policy.predict(observation, deterministic=deterministic)

    def _predict_dict(self, observation: dict, space: gym.spaces.Dict, deterministic: bool) -> tuple[np.ndarray, Any]:
        first = next(iter(space.spaces))
        single = np.shape(observation[first]) == tuple(space[first].shape)
        batch = as_obs_dict({k: np.asarray(observation[k])[None] if single else np.asarray(observation[k])
                             for k in space.spaces}, space, next(self.policy.net.parameters()).device)
        actions = eval_actions(self.policy.net, batch, deterministic)
        return (actions[0] if single else actions), None

    # ----- parameters and files -----------------------------------------------------------------------
    def get_parameters(self) -> dict[str, dict[str, torch.Tensor]]:
        """``{'policy': state_dict}`` (copies)."""
        return {"policy": {k: v.detach().clone() for k, v in self.policy.state_dict().items()}}

    def set_parameters(self, load_path_or_dict: str | dict[str, Any], exact_match: bool = True) -> None:
        """Load ``{'policy': state_dict}`` (or a file :meth:`save` wrote, or SB3's ``.zip`` of this algorithm, read as
        data); the next ``learn`` starts from them."""
        params = load_path_or_dict
        if isinstance(params, (str, os.PathLike)):
            path = model_file(os.fspath(params))
            files.load_into(self.policy, files.read_weights(path, self.algo), path, "this model", exact_match)
            self._weights_changed = True
            return
        self.policy.load_state_dict(params["policy"], strict=exact_match)
        self._weights_changed = True

    def save(self, path: str) -> str:
        """Write the model (config, arguments, spaces, weights); returns the path. Without an extension, or with
        ``.zip``, as SB3 does: ``path.zip``, SB3's archive layout holding rlchain's model file
        (:mod:`rlchain.sb3.model_zip`; written by stable-baselines3 when it is installed and the network has
        SB3's MlpPolicy layout, so SB3's ``load`` reads it too). A ``.pth`` path: rlchain's model file alone."""
        path = model_file(path, must_exist=False)
        if path.endswith(".zip"):
            network = self.config["params"]["network"]
            mlp = network.get("mlp") or {}
            sb3_layout = network.get("name") in ("actor_critic", "soft_actor_critic", "dqn") and \
                "critic_mlp" not in network and str(mlp.get("activation")) in TORCH_ACTIVATIONS

            def write_sb3(target: str) -> str:
                return write_sb3_archive(target, self.algo, (self._spaces.observation_space,
                                         self._spaces.action_space), self.hyperparameters, mlp["units"],
                                         TORCH_ACTIVATIONS[str(mlp["activation"])], self.policy.state_dict(),
                                         self.num_timesteps)
            return write_model_zip(path, self._save_own, write_sb3 if sb3_layout else None,
                                   self.policy.state_dict(), self.num_timesteps)
        return self._save_own(path)

    def _save_own(self, path: str) -> str:
        """rlchain's model file (plain data, :mod:`rlchain.sb3.files`) at ``path``."""
        keep = self.env_source.env_name if self.env_source and self.env_source.num_envs is None \
            and self.env_source.env_name in gym.registry else None
        state = {"algo": self.algo, "policy": self.policy_name, "env_id": keep, "n_envs": self.n_envs,
                 "seed": self.seed,
                 "policy_kwargs": stored_policy_kwargs(self.policy_kwargs), "hyperparameters": self.hyperparameters,
                 "config": self.config, "model": self.policy.net.state_dict(), "num_timesteps": self.num_timesteps}
        files.save_model(state, (self._spaces.observation_space, self._spaces.action_space), path)
        return path

    @classmethod
    def load(cls, path: str, env: Any = None, device: str = "auto", print_system_info: bool = False,
             **kwargs: Any) -> BaseModel:
        """A model :meth:`save` wrote (or SB3 saved); ``env`` (default: the gymnasium id it was trained on, if any)
        is needed only to train further. ``kwargs`` replace saved hyperparameters. The file is read as data (see
        :mod:`rlchain.sb3.model_load`); its stored config gives shapes and hyperparameters only.
        ``print_system_info``: print the system the archive was saved on and this one, as SB3 does."""
        return load_model(cls, path, env, device, print_system_info, kwargs)

    def get_env(self) -> Any:
        """The training env as a Stable-Baselines3 ``VecEnv`` (see :func:`rlchain.sb3.envs.sb3_vec_env`): what
        ``evaluate_policy(model, model.get_env())`` and callbacks' ``training_env`` take. None without an env."""
        if self.env_source is None:
            return None
        if getattr(self, "_vec_env", None) is None:
            self._vec_env = sb3_vec_env(self._env_arg, self.env_source, self.n_envs, self.seed)
            if self.env_source.vec_env is None:  # one SB3 made of the argument: reset, as SB3's learn leaves it
                self._vec_env.reset()  # (a callback's training_env.render() needs a reset env)
        return self._vec_env

    def set_env(self, env: Any, force_reset: bool = True) -> None:
        """Train on ``env`` from now on (its spaces must be the model's); the next ``learn`` starts a new run."""
        source = env_source(env, self.algo)
        n_envs = source.num_envs or self.n_envs
        old, self.env_source, self._env_arg, self.n_envs = (self.env_source, self._env_arg, self.n_envs), source, \
            env, n_envs
        try:
            spaces = self._read_spaces()
        except Exception:
            self.env_source, self._env_arg, self.n_envs = old
            raise
        if (spaces.observation_space, spaces.action_space) != (self._spaces.observation_space,
                                                               self._spaces.action_space):
            self.env_source, self._env_arg, self.n_envs = old
            raise ValueError(f"rlchain.{self.algo.upper()}.set_env: {source.label} has spaces "
                             f"{spaces.observation_space} / {spaces.action_space}, the model "
                             f"{self._spaces.observation_space} / {self._spaces.action_space}")
        self._vec_env = None
        if self._checkpoint is not None:
            self._checkpoint = None
            self._weights_changed = True

    def get_vec_normalize_env(self) -> Any:
        """The ``VecNormalize`` of an SB3 vec env the model trains on, or None."""
        return None if self.env_source is None else vec_normalize_of(self.env_source.vec_env)
