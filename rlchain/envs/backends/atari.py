"""Atari through gymnasium + ale-py with the DeepMind preprocessing, as rl_games' ``atari_gym``.

YAML (the names rl_games users write)::

    env_name: atari_gym
    env_config: {name: BreakoutNoFrameskip-v4, skip: 4, episode_life: True}

or one of rl_games' preset names as ``env_name`` (``PongNoFrameskip-v4``, ``BreakoutNoFrameskip-v4``,
``MsPacmanNoFrameskip-v4``: ``ALE/<Game>-v5`` without sticky actions, the atari_gym defaults).

One env, inside out (see :func:`make_atari_env`): ``gym.make(name, frameskip=1)`` ->
``AtariPreprocessing`` (noop reset, frame skip with a max-pool over the last two frames, 84x84
grayscale) -> :class:`EpisodicLife` -> :class:`FireReset` -> ``ClipReward`` (off by default, as in
rl_games, whose configs clip with ``reward_shaper``) -> ``FrameStackObservation`` -> uint8
observations (84, 84, 4), channels-last like rl_games (its configs leave ``cnn.permute_input`` at
True), or (4, 84, 84) with ``channels_first: True`` (the envpool layout, ``permute_input: False``).

rl_games' ``wrap_impala: True`` adds the previous reward and action to every observation (for the
``resnet_actor_critic`` network's ``require_rewards`` / ``require_last_actions``; see
:mod:`rlchain.envs.wrappers.reward_action_obs`).

Scores: with ``episode_life`` each lost life ends a training episode, but the game goes on; the
VecEnv reports the unclipped game reward and the end of the whole game
(``StepResult.game_reward`` / ``game_over``), so episode statistics, ``score_to_win`` and the
Player count whole games. Needs ``pip install rlchain[atari]`` (ale-py >= 0.9 ships the ROMs,
opencv for the resize).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from rlchain.config.errors import ConfigError
from rlchain.envs.backends.gymnasium_env import GymnasiumVecEnv
from rlchain.envs.vecenv import StepResult
from rlchain.envs.wrappers.reward_action_obs import RewardActionObs
from rlchain.errors import did_you_mean, optional_import

INSTALL_HINT = "Atari needs ale-py and opencv: pip install rlchain[atari]"
ATARI_ID = "rlchain/AtariDeepMind-v0"
"""The gymnasium id of :func:`make_atari_env` (registered by rlchain.builtins, which importing rlchain runs,
so async workers know the id too)."""

WRAPPER_OPTIONS = {"skip": 4, "noop_max": 30, "episode_life": True, "fire_reset": True, "clip_rewards": False,
                   "frame_stack": 4, "screen_size": 84, "channels_first": False}
"""env_config keys of ``atari_gym`` besides ``name``, with their defaults."""
ALE_OPTIONS = frozenset({"repeat_action_probability", "full_action_space", "mode", "difficulty",
                         "max_num_frames_per_episode"})
"""env_config keys passed on to ``gym.make`` (ale-py's AtariEnv)."""
RL_GAMES_PRESETS = {"PongNoFrameskip-v4": "ALE/Pong-v5", "BreakoutNoFrameskip-v4": "ALE/Breakout-v5",
                    "MsPacmanNoFrameskip-v4": "ALE/MsPacman-v5"}
"""rl_games' env names (env_configurations.py) -> the ALE game they make, without sticky actions."""
CONFIG = "params.config.env_config"


def import_ale() -> Any:
    """Import ale_py, register its envs with gymnasium, or raise an ImportError with the install hint."""
    ale_py = optional_import("ale_py", INSTALL_HINT)
    gym.register_envs(ale_py)
    return ale_py


class EpisodicLife(gym.Wrapper):
    """A lost life ends the training episode (``terminated``) when ``enabled``; the game goes on.

    ``reset()`` after a lost life takes one no-op step into the next life instead of restarting;
    it restarts the game when the game is over, when not ``enabled``, or when given a seed.
    Every step's info gets ``game_reward`` (the unclipped reward) and ``game_over`` (the whole
    game ended: no lives left or a time-out), enabled or not.
    """

    def __init__(self, env: gym.Env, enabled: bool = True) -> None:
        super().__init__(env)
        self.enabled = enabled
        self.lives = 0
        self.game_over = True

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        self.game_over = bool(terminated or truncated)
        lives = self.env.unwrapped.ale.lives()
        if self.enabled and 0 < lives < self.lives:
            terminated = True
        self.lives = lives
        info = {**info, "game_reward": float(reward), "game_over": self.game_over}
        return obs, reward, terminated, truncated, info

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict]:
        if self.enabled and not self.game_over and seed is None:
            obs, _, terminated, truncated, info = self.env.step(0)
            if not (terminated or truncated):
                self.lives = self.env.unwrapped.ale.lives()
                return obs, info
        obs, info = self.env.reset(seed=seed, options=options)
        self.game_over = False
        self.lives = self.env.unwrapped.ale.lives()
        return obs, info


class FireReset(gym.Wrapper):
    """Press FIRE (then action 2) after each reset, for games that wait for it (DeepMind's wrapper)."""

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict]:
        self.env.reset(seed=seed, options=options)
        for action in (1, 2):
            obs, _, terminated, truncated, info = self.env.step(action)
            if terminated or truncated:
                obs, info = self.env.reset(seed=seed, options=options)
        return obs, info


def make_atari_env(name: str, skip: int = 4, noop_max: int = 30, episode_life: bool = True,
                   fire_reset: bool = True, clip_rewards: bool = False, frame_stack: int = 4,
                   screen_size: int = 84, channels_first: bool = False, **ale_kwargs: Any) -> gym.Env:
    """One Atari env with the DeepMind wrappers (module docstring); ``ale_kwargs`` go to ``gym.make``.

    Observations: uint8 (screen, screen, frame_stack), or (frame_stack, screen, screen) when
    ``channels_first``. ``name``: any ale-py id (``ALE/Pong-v5``, ``PongNoFrameskip-v4``, ...).
    """
    import_ale()
    env = gym.make(name, frameskip=1, **ale_kwargs)
    env = gym.wrappers.AtariPreprocessing(env, noop_max=noop_max, frame_skip=skip, screen_size=screen_size,
                                          terminal_on_life_loss=False, grayscale_obs=True, scale_obs=False)
    env = EpisodicLife(env, enabled=episode_life)
    if fire_reset and "FIRE" in env.unwrapped.get_action_meanings():
        env = FireReset(env)
    if clip_rewards:
        env = gym.wrappers.ClipReward(env, -1.0, 1.0)
    env = gym.wrappers.FrameStackObservation(env, frame_stack)
    if not channels_first:
        space = gym.spaces.Box(0, 255, (screen_size, screen_size, frame_stack), np.uint8)
        env = gym.wrappers.TransformObservation(env, lambda obs: np.moveaxis(obs, 0, -1), space)
    return env


def info_column(infos: dict, key: str, done: np.ndarray, dtype: Any) -> np.ndarray | None:
    """Per-env ``infos[key]`` of a same-step autoreset vector step, (N,); None when no env sent it.

    Rows that ended hold the info of their last step in ``infos['final_info']`` (the top level has
    the next episode's reset info there).
    """
    if key not in infos:
        return None
    column = np.asarray(infos[key], dtype=dtype).copy()
    final = infos.get("final_info")
    if done.any() and isinstance(final, dict) and key in final:
        column[done] = np.asarray(final[key], dtype=dtype)[done]
    return column


class AtariVecEnv(GymnasiumVecEnv):
    """``num_envs`` :func:`make_atari_env` envs (gymnasium sync or async vector env).

    ``step`` adds ``game_reward`` / ``game_over`` to the StepResult (see the module docstring).
    """

    def __init__(self, num_envs: int, options: dict, mode: str = "sync", render: bool = False,
                 seed: int | None = None) -> None:
        import_ale()
        super().__init__(ATARI_ID, num_envs, mode=mode, env_kwargs=options, render=render, seed=seed)

    def step(self, actions: np.ndarray) -> StepResult:
        result = super().step(actions)
        done = np.asarray(result.terminated) | np.asarray(result.truncated)
        result.game_reward = info_column(result.infos, "game_reward", done, np.float32)
        result.game_over = info_column(result.infos, "game_over", done, bool)
        return result


def atari_options(env_config: dict) -> dict:
    """Check an ``atari_gym`` env_config and return :func:`make_atari_env`'s keyword arguments.

    rl_games keys: ``wrap_impala`` (handled by :func:`atari_gym_env`) is left out of the result;
    ``sticky: True`` becomes ale-py's ``repeat_action_probability: 0.25``.
    """
    options = dict(env_config)
    if "name" not in options:
        raise ConfigError("", f"{CONFIG}.name", "is required with env_name atari_gym (an ale-py id, "
                                                "e.g. BreakoutNoFrameskip-v4 or ALE/Pong-v5)")
    options.pop("wrap_impala", None)  # read by atari_gym_env
    if options.pop("sticky", False):
        options.setdefault("repeat_action_probability", 0.25)
    valid = {"name", *WRAPPER_OPTIONS, *ALE_OPTIONS}
    for key in options:
        if key not in valid:
            hint = did_you_mean(key, sorted(valid))
            raise ConfigError("", f"{CONFIG}.{key}",
                              f"not an atari_gym option{hint} (valid: {', '.join(sorted(valid))})")
    return options


def _mode(vecenv_type: str | None) -> str:
    kind = "auto" if vecenv_type is None else str(vecenv_type).lower()
    if kind not in ("auto", "sync", "async"):
        raise ConfigError("", "params.config.vecenv_type", f"'{vecenv_type}' does not apply to Atari through "
                                                           "gymnasium (auto, sync or async); for envpool use "
                                                           "env_name: envpool")
    return "sync" if kind == "auto" else kind


def atari_gym_env(num_envs: int, seed: int | None, *, vecenv_type: str | None = None, render: bool = False,
                  **env_config: Any) -> AtariVecEnv | RewardActionObs:
    """``env_name: atari_gym`` (rl_games' name): an ale-py id in ``env_config.name`` plus wrapper options.

    ``wrap_impala: True`` (rl_games' ImpalaEnvWrapper) adds the previous reward and action to the
    observations, for ``resnet_actor_critic`` with ``require_rewards`` / ``require_last_actions``.
    """
    env = AtariVecEnv(num_envs, atari_options(env_config), _mode(vecenv_type), render, seed)
    return RewardActionObs(env, f"{CONFIG}.wrap_impala") if env_config.get("wrap_impala") else env


def preset_env(name: str) -> Any:
    """The builder of rl_games' preset env ``name`` (``env_name: PongNoFrameskip-v4``).

    Like rl_games it ignores ``env_config.env_name`` / ``has_lives``; other atari_gym options apply.
    """

    def build(num_envs: int, seed: int | None, *, vecenv_type: str | None = None, render: bool = False,
              **env_config: Any) -> AtariVecEnv:
        env_config.pop("env_name", None)
        env_config.pop("has_lives", None)
        options = {"name": RL_GAMES_PRESETS[name], "repeat_action_probability": 0.0, **env_config}
        return atari_gym_env(num_envs, seed, vecenv_type=vecenv_type, render=render, **options)

    build.__name__ = f"atari_preset_{name}"
    return build


ENV_BUILDERS = {"atari_gym": atari_gym_env, **{name: preset_env(name) for name in RL_GAMES_PRESETS}}
"""``env_name`` -> builder, for :data:`rlchain.registry.ENVS` (rlchain.builtins registers them)."""
