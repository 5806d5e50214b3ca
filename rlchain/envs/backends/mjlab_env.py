"""mjlab (Isaac Lab's manager-based API on MuJoCo Warp) as a tensor env.

Two spellings build it:

- rlchain's: ``env_name: mjlab`` with ``env_config.task_name`` (any registered mjlab task, e.g.
  ``Mjlab-Velocity-Flat-Unitree-Go1``);
- rl_games 2.0's: ``vecenv_type: MJLAB`` with any ``env_name`` (its YAMLs say ``mjlab_go1_velocity``) and
  the task in ``env_config.task_name``, so rl_games' ``configs/mjlab/*.yaml`` run as written.

``env_config`` keys: ``task_name`` (required), ``device`` (``cpu``, ``cuda`` or ``cuda:N``; default cuda when
there is one, else cpu; under torchrun each rank's own GPU), ``play`` (build the task's play config: no
observation noise or pushes) and ``random_episode_start`` (start every env at a random step of its first
episode, as rsl_rl's ``init_at_random_ep_len`` does, so time-outs do not all come at once; default false, as
rl_games). The run's seed seeds mjlab (``cfg.seed``: torch, numpy and Warp's generators).

What the trainer sees: mjlab's ``actor`` observation group (``policy`` in Isaac Lab-style task plugins) as the
observation; with a ``critic`` group the observation is ``[actor | critic]`` in an
:class:`~rlchain.envs.wrappers.central_value.ObsStateBox`, so the actor reads ``obs`` (the actor group) and
``central_value_config``'s critic ``state`` (the critic group), the asymmetric critic rl_games' mjlab configs
train. A ``multi_input`` network gets the groups per key instead (:meth:`MjlabVecEnv.keep_keys_apart`: keys
``actor`` and ``critic``, or ``actor/<term>`` for a group that keeps its terms apart). Time-outs are
``truncated`` (bootstrapped with ``value_bootstrap``) unless the task is finite-horizon, where mjlab itself
treats them as terminal. mjlab's episode log (``Episode_Reward/*``, ``Episode_Termination/*``, ``Curriculum/*``,
``Metrics/*``) is in ``infos['episode']`` at the steps where envs reset (rl_games' isaac
observer writes it as ``Episode/<key>``; ``log_info_keys`` can name its keys) and is written every epoch under
its own names, as rsl_rl writes it, through :meth:`MjlabVecEnv.log_stats`. Install: ``pip install
rlchain[mjlab]`` (its own environment: mjlab pins mujoco 3.11, the other extras mujoco 4).
"""

from __future__ import annotations

import contextlib
import os
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.config.errors import ConfigError
from rlchain.envs.backends.tensor_env import resolve_env_device
from rlchain.envs.vecenv import StepResult
from rlchain.envs.wrappers.central_value import ObsStateBox
from rlchain.envs.wrappers.dict_obs import FlatDictBox
from rlchain.errors import did_you_mean

INSTALL_HINT = "mjlab is not installed: pip install rlchain[mjlab] (or pip install mjlab)"
OPTIONS = ("task_name", "device", "play", "random_episode_start")
WHERE = "params.config.env_config"
ACTOR_GROUPS = ("actor", "policy")  # mjlab's name, then Isaac Lab's
CRITIC_GROUP = "critic"


def import_mjlab() -> tuple[Any, Any]:
    """(``mjlab.tasks.registry``, ``ManagerBasedRlEnv``), or an ImportError naming the extra."""
    try:
        import mjlab.tasks  # noqa: F401  (optional: mjlab; importing it registers its tasks)
        from mjlab.envs import ManagerBasedRlEnv
        from mjlab.tasks import registry
    except ImportError as exc:
        raise ImportError(INSTALL_HINT) from exc
    return registry, ManagerBasedRlEnv


def build_mjlab_env(task_name: str, num_envs: int, seed: int | None, device: str, play: bool = False) -> Any:
    """The mjlab ``ManagerBasedRlEnv`` of ``task_name`` with ``num_envs`` envs on ``device``, seeded with ``seed``."""
    registry, env_class = import_mjlab()
    tasks = registry.list_tasks()
    if task_name not in tasks:
        raise ConfigError("", f"{WHERE}.task_name", f"mjlab has no task '{task_name}'{did_you_mean(task_name, tasks)}"
                                                    f" (its tasks: {', '.join(tasks)})")
    with contextlib.suppress(ImportError):  # Warp compiles kernels on first use; its per-kernel lines are noise
        import warp

        warp.config.quiet = True
    cfg = registry.load_env_cfg(task_name, play=play)
    cfg.scene.num_envs = int(num_envs)
    if seed is not None:
        cfg.seed = int(seed)
    return env_class(cfg=cfg, device=device)


def _entries(value: Any, name: str) -> list[tuple[str, gym.spaces.Box]]:
    """The keys one observation group gives per key, in :func:`_flat`'s order: the group itself (``actor``) when
    it is one tensor, else each term as ``group/term`` (``actor/joint_pos``; a group of ``concatenate_terms:
    False``), a float32 Box of one row's shape."""
    if isinstance(value, dict):
        return [entry for k, v in value.items() for entry in _entries(v, f"{name}/{k}")]
    return [(name, gym.spaces.Box(-np.inf, np.inf, tuple(value.shape[1:]), np.float32))]


def _flat(value: Any, group: str) -> torch.Tensor:
    """One observation group as (N, features) float32: a concatenated group as it is, a dict of terms in order."""
    if isinstance(value, torch.Tensor):
        return value.reshape(value.shape[0], -1).float()
    if isinstance(value, dict):
        return torch.cat([_flat(v, f"{group}.{k}") for k, v in value.items()], -1)
    raise TypeError(f"mjlab observation group '{group}' is a {type(value).__name__}, expected a tensor or a dict")


class MjlabVecEnv:
    """An mjlab ``ManagerBasedRlEnv`` as an rlchain tensor VecEnv (see the module docstring)."""

    is_tensor_env = True

    def __init__(self, env: Any, random_episode_start: bool = False) -> None:
        self.env = env
        self.num_envs = int(env.num_envs)
        self.device = torch.device(env.device)
        obs, _ = env.reset()
        self.actor_key = next((k for k in ACTOR_GROUPS if k in obs), None)
        if self.actor_key is None:
            raise ValueError(f"the mjlab task has no '{ACTOR_GROUPS[0]}' (or '{ACTOR_GROUPS[1]}') observation group; "
                             f"its groups: {', '.join(obs)}")
        self.has_critic = self.use_central_value = CRITIC_GROUP in obs
        # the entries per key (keep_keys_apart): the actor group's, then the critic group's
        self._keyed = _entries(obs[self.actor_key], self.actor_key) + (
            _entries(obs[CRITIC_GROUP], CRITIC_GROUP) if self.has_critic else [])
        actor_size = _flat(obs[self.actor_key], self.actor_key).shape[-1]
        actor_space = gym.spaces.Box(-np.inf, np.inf, (actor_size,), np.float32)
        if self.use_central_value:
            critic_size = _flat(obs[CRITIC_GROUP], CRITIC_GROUP).shape[-1]
            self.observation_space: gym.Space = ObsStateBox(
                actor_size, critic_size, obs_space=actor_space,
                state_space=gym.spaces.Box(-np.inf, np.inf, (critic_size,), np.float32))
        else:
            self.observation_space = actor_space
        actions = int(np.prod(env.single_action_space.shape))
        # mjlab's action terms scale and offset the raw action themselves; rl_games' wrapper declares [-1, 1]
        self.action_space = gym.spaces.Box(-1.0, 1.0, (actions,), np.float32)
        self.finite_horizon = bool(getattr(env.cfg, "is_finite_horizon", False))
        self._obs = self._obs_of(obs)
        self._random_start = bool(random_episode_start)
        self._log_sums: dict[str, float] = {}
        self._log_counts: dict[str, int] = {}

    def keep_keys_apart(self) -> MjlabVecEnv:
        """For a network that takes the observations per key (``multi_input``): the observation space becomes a
        :class:`~rlchain.envs.wrappers.dict_obs.FlatDictBox` of the actor group's entries and the critic group's
        (:func:`_entries`), which ``PerKeyObs`` hands on per key; the critic group is then a key like the others
        (a ``multi_input`` central value reads it, the actor leaves it out with ``encoder: none``), not the
        ``[obs | state]`` layout. The flat rows are the same values in the same order. Returns this env."""
        self.observation_space = FlatDictBox(gym.spaces.Dict(self._keyed), np.float32)
        self.use_central_value = False
        return self

    def _obs_of(self, obs: dict) -> torch.Tensor:
        """The rows the trainer reads: the actor group, then the critic group when there is one."""
        actor = _flat(obs[self.actor_key], self.actor_key)
        if not self.has_critic:
            return actor
        return torch.cat([actor, _flat(obs[CRITIC_GROUP], CRITIC_GROUP)], -1)

    def reset(self, seed: int | None = None) -> torch.Tensor:
        """Reset every env (``seed`` reseeds mjlab's generators); (N, obs) float32 on ``device``."""
        obs, _ = self.env.reset(seed=seed) if seed is not None else self.env.reset()
        if self._random_start:  # rsl_rl's init_at_random_ep_len: spread the first time-outs over an episode
            length = int(self.env.max_episode_length)
            buf = self.env.episode_length_buf
            self.env.episode_length_buf = torch.randint_like(buf, high=max(length, 1))
        self._obs = self._obs_of(obs)
        return self._obs

    def step(self, actions: Any) -> StepResult:
        """One step of every env with actions (N, action) on ``device``; mjlab resets finished envs itself.

        mjlab does not return the last observation of a reset env: ``final_obs`` is the observation before the
        step, so time-out bootstrapping uses V(s_T-1), as rsl_rl and rl_games bootstrap mjlab's time-outs."""
        if not isinstance(actions, torch.Tensor):
            actions = torch.as_tensor(np.asarray(actions))
        prev = self._obs
        obs, reward, terminated, truncated, extras = self.env.step(actions.to(self.device, torch.float32))
        terminated, truncated = terminated.bool(), truncated.bool()
        if self.finite_horizon:  # mjlab's rule: a finite-horizon task's time-out is terminal, never bootstrapped
            terminated, truncated = terminated | truncated, torch.zeros_like(truncated)
        infos: dict[str, Any] = {"time_outs": truncated}
        log = extras.get("log") if isinstance(extras, dict) else None
        if log:  # mjlab reuses the dict and its tensors from step to step: copy the values
            episode = {k: v.detach().clone() if isinstance(v, torch.Tensor) else v for k, v in log.items()}
            infos["episode"] = episode
            self._fold_log(episode)
        self._obs = self._obs_of(obs)
        return StepResult(self._obs, reward.reshape(-1).float(), terminated, truncated, prev, infos)

    def _fold_log(self, episode: dict) -> None:
        for key, value in episode.items():
            try:
                number = float(torch.as_tensor(value, dtype=torch.float32).mean())
            except (TypeError, ValueError, RuntimeError):
                continue
            if np.isfinite(number):
                self._log_sums[key] = self._log_sums.get(key, 0.0) + number
                self._log_counts[key] = self._log_counts.get(key, 0) + 1

    def log_stats(self) -> dict[str, float]:
        """mjlab's episode log since the last call, each key's mean over the steps that reported it, under
        its own name (``Episode_Reward/track_lin_vel``, ``Curriculum/...``): the tags rsl_rl writes."""
        out = {k: self._log_sums[k] / self._log_counts[k] for k in self._log_sums}
        self._log_sums, self._log_counts = {}, {}
        return out

    def seed(self, seed: int) -> None:
        """Reseed mjlab's generators (torch, numpy, Warp)."""
        self.env.seed(int(seed))

    def close(self) -> None:
        self.env.close()

    def __repr__(self) -> str:
        return f"MjlabVecEnv(num_envs={self.num_envs}, device={self.device})"


def default_device() -> str:
    """cuda when torch sees one (under torchrun the rank's own), else cpu."""
    if not torch.cuda.is_available():
        return "cpu"
    rank = os.environ.get("LOCAL_RANK")
    return f"cuda:{rank}" if rank is not None else "cuda"


def mjlab_env(num_envs: int, seed: int | None, *, render: bool = False, **env_config: Any) -> MjlabVecEnv:
    """``env_name: mjlab``: the mjlab task ``env_config.task_name`` (the other keys: the module docstring)."""
    for key in env_config:
        if key not in OPTIONS:
            raise ConfigError("", f"{WHERE}.{key}", f"not an mjlab option (valid: {', '.join(OPTIONS)})"
                                                    f"{did_you_mean(key, OPTIONS)}")
    task = env_config.get("task_name")
    if not isinstance(task, str) or not task:
        raise ConfigError("", f"{WHERE}.task_name", "is required with mjlab (a registered mjlab task, e.g. "
                                                    "Mjlab-Velocity-Flat-Unitree-Go1)")
    for key in ("play", "random_episode_start"):
        if not isinstance(env_config.get(key, False), bool):
            raise ConfigError("", f"{WHERE}.{key}", f"expected true or false, got {env_config[key]!r}")
    try:
        device = str(resolve_env_device(env_config.get("device") or default_device()))
    except ValueError as exc:
        raise ConfigError("", f"{WHERE}.device", str(exc).split(": ", 1)[-1]) from None
    env = build_mjlab_env(task, num_envs, seed, device, play=bool(env_config.get("play", False)))
    try:
        return MjlabVecEnv(env, random_episode_start=bool(env_config.get("random_episode_start", False)))
    except BaseException:
        env.close()
        raise


def mjlab_vecenv(config_name: str, num_actors: int, seed: int | None = None, render: bool = False,
                 **env_config: Any) -> MjlabVecEnv:
    """``vecenv_type: MJLAB`` (rl_games 2.0's creator signature): ``env_name`` is a label, the task is
    ``env_config.task_name``."""
    return mjlab_env(num_actors, seed, render=render, **env_config)


__all__ = ["MjlabVecEnv", "mjlab_env", "mjlab_vecenv", "build_mjlab_env", "INSTALL_HINT"]
