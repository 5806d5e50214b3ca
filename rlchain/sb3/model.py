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
from rlchain.envs.obs_dict import as_obs_dict
from rlchain.models.build import build_env, build_model
from rlchain.runner import Runner
from rlchain.runs import checkpoint as ckpt
from rlchain.sb3.envs import EnvSource, env_source
from rlchain.sb3.keys import NUM_ENVS, build_config
from rlchain.training.events import Callback

FORMAT = "rlchain-sb3-1"
POLICIES = {"MlpPolicy": None, "MultiInputPolicy": "multi_input"}
"""SB3's policy names -> the rlchain network they map to (None: the algorithm's default network). MultiInputPolicy:
Dict observations, an encoder per key (docs/robot_learning.md)."""


class _Spaces:
    """The observation and action spaces of the trained env: enough to build the policy network."""

    num_envs = 1

    def __init__(self, observation_space: Any, action_space: Any) -> None:
        self.observation_space = observation_space
        self.action_space = action_space


class _Bridge(Callback):
    """Hands the model's weights to the run when they changed since the last run, and takes the trained
    weights back when it ends."""

    def __init__(self, model: BaseModel) -> None:
        self.model = model

    def on_train_start(self, ctx: Any) -> None:
        if self.model._weights_changed:
            ctx.model.load_state_dict(self.model.policy.state_dict())

    def on_train_end(self, ctx: Any, result: Any) -> None:
        self.model.policy.load_state_dict(copy.deepcopy(ctx.model.state_dict()))
        self.model._weights_changed = False


class BaseModel:
    """What PPO, SAC and DQN share; see the module docstring."""

    algo: ClassVar[str] = ""

    def __init__(self, policy: str, env: Any, *, n_envs: int | None = None, seed: int | None = None,
                 device: str = "auto", verbose: int = 1, tensorboard_log: str | None = None,
                 policy_kwargs: dict[str, Any] | None = None, **hyperparameters: Any) -> None:
        source = f"rlchain.{self.algo.upper()}"
        if policy not in POLICIES:
            raise ConfigError(source, "policy", f"'{policy}' is not supported (choices: {', '.join(POLICIES)}); "
                                                f"other networks: the network block of an rlchain YAML")
        self.policy_name = policy
        self.env_source: EnvSource | None = None if env is None else env_source(env, self.algo)
        fixed = None if self.env_source is None else self.env_source.num_envs
        if fixed is not None and n_envs is not None and n_envs != fixed:
            raise ConfigError(source, "n_envs", f"{n_envs}, but {self.env_source.label} is {fixed} env(s)")
        self.n_envs = fixed or n_envs or NUM_ENVS[self.algo]
        self.seed = seed
        self.device = ("cuda:0" if torch.cuda.is_available() else "cpu") if device == "auto" else device
        self.verbose = verbose
        self.tensorboard_log = tensorboard_log
        self.policy_kwargs = dict(policy_kwargs or {})
        self.hyperparameters = dict(hyperparameters)
        self.num_timesteps = 0
        self._checkpoint: str | None = None  # the last run's last checkpoint: a later learn resumes it
        self._weights_changed = False
        self._spaces: _Spaces | None = None
        self._loaded_config: dict[str, Any] | None = None  # load() without an env: the saved config
        self.policy: torch.nn.Module | None = None
        if self.env_source is not None:
            self._spaces = self._read_spaces()
            self.policy = self._build_policy()

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
        config = build_config(self.algo, self.env_source.env_name, self.n_envs, continuous, self.hyperparameters,
                              keys, self.policy_kwargs, total_timesteps, self.seed, run)
        if POLICIES[self.policy_name] is not None:
            config["params"]["network"]["name"] = POLICIES[self.policy_name]
        return config

    @property
    def config(self) -> dict[str, Any]:
        """The rl_games-style config this model trains with (``{'params': ...}``)."""
        if self.env_source is None and self._loaded_config is not None:
            return copy.deepcopy(self._loaded_config)
        return self._config()

    def save_config(self, path: str, total_timesteps: int | None = None) -> str:
        """Write :attr:`config` as YAML (with ``max_frames`` when ``total_timesteps`` is given): ``rlchain train
        <path>`` runs it (for an env object or callable, register the env under its name first)."""
        with open(path, "w") as f:
            yaml.safe_dump(self._config(total_timesteps), f, sort_keys=False)
        return path

    def _runner(self, total_timesteps: int | None = None) -> Runner:
        return Runner().load(self._config(total_timesteps))

    def _read_spaces(self) -> _Spaces:
        runner = self._runner()  # checks every argument now, as SB3 fails in the constructor
        params = runner.params
        env = build_env(params, 1, 0)
        try:
            return _Spaces(env.observation_space, env.action_space)
        finally:
            env.close()

    def _build_policy(self) -> torch.nn.Module:
        params = self._runner().params
        if self.seed is not None:
            torch.manual_seed(self.seed)
        model = build_model(params, self._spaces, torch.device("cpu"))
        model.eval()
        return model

    # ----- training -----------------------------------------------------------------------------------
    def learn(self, total_timesteps: int, callback: Any = None, progress_bar: bool = False,
              reset_num_timesteps: bool = True, log_interval: int | None = None,
              tb_log_name: str | None = None) -> BaseModel:
        """Train for ``total_timesteps`` env frames (rounded up to whole epochs) on rlchain's loop.

        ``callback``: an rlchain :class:`~rlchain.training.events.Callback`, a function ``fn(ctx, stats,
        episodes)`` called after every epoch (``ctx.request_stop(reason)`` stops the run), or a list of them.
        ``progress_bar=True`` shows rlchain's live status line. A later call resumes this run from its last
        checkpoint; ``reset_num_timesteps`` and ``log_interval`` are accepted for SB3's signature only.
        """
        if self.policy is None:
            raise ValueError(f"rlchain.{self.algo.upper()}: no env; pass env= to load() to train")
        total = int(total_timesteps)
        callbacks = callback if isinstance(callback, (list, tuple)) else ([] if callback is None else [callback])
        overrides = []
        if progress_bar:
            overrides.append("params.config.progress.live=True")
        if tb_log_name:
            overrides.append(f"params.config.name={tb_log_name}")
        runner = Runner().load(self._config(self.num_timesteps + total), overrides)
        if self.verbose > 0 and self._checkpoint is None:
            print(f"rlchain: {type(self).__name__} runs this config (model.save_config('cfg.yaml'), then "
                  f"`rlchain train cfg.yaml`):\n{yaml.safe_dump(self._config(total), sort_keys=False)}", flush=True)
        result = runner.train(checkpoint=self._checkpoint, seed=self.seed, callbacks=[_Bridge(self), *callbacks])
        self.num_timesteps = int(result.frames)
        self.run_dir = result.run_dir
        last = os.path.join(result.run_dir, "nn", f"last_{runner.params.config.name}.pth")
        self._checkpoint = last if os.path.isfile(last) else None
        self.result = result
        return self

    # ----- acting -------------------------------------------------------------------------------------
    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        """``(actions, state)`` for one observation or a batch of them, as SB3 returns them (``state`` is
        None: MlpPolicy has no memory)."""
        if self.policy is None:
            raise ValueError(f"rlchain.{self.algo.upper()}: no policy yet; construct with an env or load()")
        space = self._spaces.observation_space
        if isinstance(space, gym.spaces.Dict):  # MultiInputPolicy: {key: one observation or a batch}
            return self._predict_dict(observation, space, deterministic)
        obs = np.asarray(observation, dtype=np.float32)
        single = obs.shape == tuple(space.shape)
        batch = torch.as_tensor(obs[None] if single else obs.reshape(-1, *space.shape))
        with torch.inference_mode():
            actions = self.policy.dist.to_env(self.policy.act(batch, deterministic=deterministic)["actions"])
        actions = actions.cpu().numpy()
        return (actions[0] if single else actions), None

    def _predict_dict(self, observation: dict, space: gym.spaces.Dict, deterministic: bool) -> tuple[np.ndarray, Any]:
        first = next(iter(space.spaces))
        single = np.shape(observation[first]) == tuple(space[first].shape)
        batch = as_obs_dict({k: np.asarray(observation[k])[None] if single else np.asarray(observation[k])
                             for k in space.spaces}, space, "cpu")
        with torch.inference_mode():
            actions = self.policy.dist.to_env(self.policy.act(batch, deterministic=deterministic)["actions"])
        actions = actions.cpu().numpy()
        return (actions[0] if single else actions), None

    # ----- parameters and files -----------------------------------------------------------------------
    def get_parameters(self) -> dict[str, dict[str, torch.Tensor]]:
        """``{'policy': state_dict}`` (copies)."""
        return {"policy": {k: v.detach().clone() for k, v in self.policy.state_dict().items()}}

    def set_parameters(self, load_path_or_dict: str | dict[str, Any], exact_match: bool = True) -> None:
        """Load ``{'policy': state_dict}`` (or a file :meth:`save` wrote); the next ``learn`` starts from them."""
        params = load_path_or_dict
        if isinstance(params, str):
            params = {"policy": torch.load(_file(params), map_location="cpu", weights_only=False)["model"]}
        self.policy.load_state_dict(params["policy"], strict=exact_match)
        self._weights_changed = True

    def save(self, path: str) -> str:
        """Write the model (config, arguments, spaces, weights) to ``path``
        (``.pth`` added when it has no extension); returns the path."""
        path = _file(path, must_exist=False)
        keep = self.env_source.env_name if self.env_source and self.env_source.num_envs is None \
            and self.env_source.env_name in gym.registry else None
        state = {"format": FORMAT, "algo": self.algo, "policy": self.policy_name, "env_id": keep, "n_envs": self.n_envs, "seed": self.seed,
                 "policy_kwargs": self.policy_kwargs, "hyperparameters": self.hyperparameters,
                 "spaces": (self._spaces.observation_space, self._spaces.action_space),
                 "config": self.config, "model": self.policy.state_dict(), "num_timesteps": self.num_timesteps}
        ckpt.save_atomic(state, path)
        return path

    @classmethod
    def load(cls, path: str, env: Any = None, device: str = "auto", **kwargs: Any) -> BaseModel:
        """A model :meth:`save` wrote; ``env`` (default: the gymnasium id it was trained on, if any) is needed
        only to train further. ``kwargs`` replace saved hyperparameters."""
        state = torch.load(_file(path), map_location="cpu", weights_only=False)
        if not isinstance(state, dict) or state.get("format") != FORMAT:
            raise ValueError(f"{path}: not a model saved by rlchain.{cls.algo.upper()}.save "
                             f"(for a training checkpoint use rlchain.Runner or `rlchain play`)")
        if state["algo"] != cls.algo:
            raise ValueError(f"{path}: a {state['algo'].upper()} model; load it with rlchain.{state['algo'].upper()}")
        env = env if env is not None else state["env_id"]
        hyperparameters = {**state["hyperparameters"], **kwargs}
        model = cls.__new__(cls)
        BaseModel.__init__(model, state.get("policy", "MlpPolicy"), None, n_envs=state["n_envs"] if env is not None else None,
                           seed=state["seed"], device=device, policy_kwargs=state["policy_kwargs"],
                           **hyperparameters)
        if env is not None:
            model.env_source = env_source(env, cls.algo)
            model.n_envs = model.env_source.num_envs or state["n_envs"]
        model._spaces = _Spaces(*state["spaces"])
        model._loaded_config = state["config"]
        model.policy = model._build_policy_from(state["config"])
        model.policy.load_state_dict(state["model"])
        model.num_timesteps = state["num_timesteps"]
        model._weights_changed = True
        return model

    def _build_policy_from(self, config: dict[str, Any]) -> torch.nn.Module:
        params = Runner().load(copy.deepcopy(config)).params if self.env_source is None else self._runner().params
        model = build_model(params, self._spaces, torch.device("cpu"))
        model.eval()
        return model

    def get_env(self) -> Any:
        """The env argument's rlchain name (a gymnasium id, or the name its env object was registered under)."""
        return None if self.env_source is None else self.env_source.env_name


def _file(path: str, must_exist: bool = True) -> str:
    """``path``, or ``path.pth`` when it has no extension (SB3 adds ``.zip`` the same way)."""
    path = os.fspath(path)
    if os.path.splitext(path)[1]:
        return path
    if must_exist and os.path.exists(path) and not os.path.exists(path + ".pth"):
        return path
    return path + ".pth"
