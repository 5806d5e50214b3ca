"""Recording a policy's episodes to mp4 with gymnasium's RecordVideo (``pip install rlchain[video]``).

Only gymnasium ids are supported (``env_name: CartPole-v1`` or ``env_name: openai_gym`` with
``env_config.name``): the env is made once with ``render_mode='rgb_array'`` and played by the one play
loop (:func:`rlchain.policy.play.play`). From a checkpoint: :func:`rlchain.inference.video.record_episodes`;
during training: :class:`rlchain.training.video_callback.VideoCallback`.
"""

from __future__ import annotations

import glob
import os
from typing import Any

import torch

from rlchain.config.errors import ConfigError
from rlchain.config.params import Params
from rlchain.envs.wrappers.one_env import OneEnv
from rlchain.errors import optional_import
from rlchain.log import get_logger
from rlchain.policy.play import play

log = get_logger(__name__)

INSTALL_HINT = "video recording needs moviepy and pygame: pip install rlchain[video]"
_NOT_ENV_KWARGS = ("seed", "name")


def require_moviepy() -> None:
    optional_import("moviepy", INSTALL_HINT)


def gym_id_of(params: Params) -> tuple[str, dict]:
    """The gymnasium id and ``gym.make`` kwargs of the config (player.env_config applied)."""
    import gymnasium as gym

    cfg = params.config
    kwargs = dict(cfg.env_config)
    kwargs.update(cfg.player.env_config or {})
    env_id = kwargs.get("name") if cfg.env_name == "openai_gym" else cfg.env_name
    try:
        gym.spec(env_id)
    except (gym.error.Error, ImportError, TypeError):
        raise ConfigError(params.source, "params.config.env_name",
                          f"video recording needs a gymnasium id env, not '{cfg.env_name}'") from None
    for key in _NOT_ENV_KWARGS:
        kwargs.pop(key, None)
    return env_id, kwargs


def make_recording_env(params: Params, video_dir: str, name_prefix: str = "rl-video") -> Any:
    """One gymnasium env with ``render_mode='rgb_array'`` wrapped in RecordVideo (every episode)."""
    import gymnasium as gym
    from gymnasium.wrappers import RecordVideo

    require_moviepy()
    env_id, kwargs = gym_id_of(params)
    try:
        env = gym.make(env_id, render_mode="rgb_array", **kwargs)
        return RecordVideo(env, video_dir, episode_trigger=lambda _: True, name_prefix=name_prefix,
                           disable_logger=True)
    except gym.error.DependencyNotInstalled as exc:
        raise ImportError(f"{INSTALL_HINT} ({exc})") from None


def record_model_episodes(model: Any, params: Params, video_dir: str, games: int = 1,
                          deterministic: bool = True, device: torch.device | str = "cpu",
                          seed: int | None = None, name_prefix: str = "rl-video") -> list[str]:
    """Play ``games`` episodes with ``model`` on a recording env; returns the mp4 paths it wrote
    (new files, and files of the same name it overwrote: a second recording into one folder)."""
    before = _mp4_times(video_dir)
    env = OneEnv(make_recording_env(params, video_dir, name_prefix), games)
    try:
        play(model, env, games, deterministic, device=torch.device(device), seed=seed, success_key="none")
    except Exception as exc:
        import gymnasium as gym

        if isinstance(exc, gym.error.DependencyNotInstalled):
            raise ImportError(f"{INSTALL_HINT} ({exc})") from None
        raise
    finally:
        env.close()  # writes the last video
    return sorted(path for path, stamp in _mp4_times(video_dir).items() if before.get(path) != stamp)


def _mp4_times(video_dir: str) -> dict[str, tuple[int, int]]:
    """{mp4 path: (modification time in ns, size)} of the folder's videos."""
    times = {}
    for path in glob.glob(os.path.join(video_dir, "*.mp4")):
        try:
            stat = os.stat(path)
        except OSError:
            continue
        times[path] = (stat.st_mtime_ns, stat.st_size)
    return times
