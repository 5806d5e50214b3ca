"""Record played episodes to mp4 with gymnasium's RecordVideo (``pip install rlchain[video]``).

    from rlchain.inference.video import record_episodes
    files = record_episodes(Runner().load("cfg.yaml").params, "nn/cartpole.pth", "videos", games=2)

or ``python runner.py --play --file cfg.yaml --checkpoint nn/cartpole.pth --video videos``.
During training, ``VideoCallback(every_n_evaluations=5)`` records one episode every 5th
in-training evaluation (``config.evaluation.interval`` > 0) into ``<run>/videos``.

Only gymnasium ids are supported (``env_name: CartPole-v1`` or ``env_name: openai_gym`` with
``env_config.name``): the env is made once with ``render_mode='rgb_array'``.
"""

from __future__ import annotations

import glob
import os
from typing import Any

import torch

from rlchain.config.errors import ConfigError
from rlchain.config.params import Params
from rlchain.envs.wrappers.one_env import OneEnv
from rlchain.inference.player import Player
from rlchain.log import get_logger
from rlchain.policy.play import play
from rlchain.training.callback_context import CallbackContext
from rlchain.training.events import Callback

log = get_logger(__name__)

INSTALL_HINT = "video recording needs moviepy and pygame: pip install rlchain[video]"
_NOT_ENV_KWARGS = ("seed", "name")


def _require_moviepy() -> None:
    try:
        import moviepy  # noqa: F401
    except ImportError:
        raise ImportError(INSTALL_HINT) from None


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

    _require_moviepy()
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


def record_episodes(params: Params, checkpoint: str | None, video_dir: str, games: int = 1,
                    deterministic: bool = True) -> list[str]:
    """Load ``checkpoint`` like the Player does and record ``games`` episodes to mp4 in ``video_dir``."""

    _require_moviepy()
    gym_id_of(params)  # fail on a non-gymnasium env before loading anything
    player = Player(params, checkpoint)
    try:
        return record_model_episodes(player.model, params, video_dir, games, deterministic,
                                     player.device, seed=player.seed)
    finally:
        player.close()


class VideoCallback(Callback):
    """Records one episode every ``every_n_evaluations``-th in-training evaluation.

    Videos go to ``video_dir`` (default ``<run folder>/videos``), named ``epoch_<N>-episode-0.mp4``.
    """

    def __init__(self, every_n_evaluations: int = 1, video_dir: str | None = None,
                 deterministic: bool = True) -> None:
        if every_n_evaluations < 1:
            raise ValueError("every_n_evaluations must be >= 1")
        _require_moviepy()
        self.every = every_n_evaluations
        self.video_dir = video_dir
        self.deterministic = deterministic
        self.count = 0
        self.files: list[str] = []

    def on_evaluation(self, ctx: CallbackContext, result: Any) -> None:
        self.count += 1
        if self.count % self.every != 0:
            return
        state = ctx.state
        folder = self.video_dir or os.path.join(state.experiment_dir or ".", "videos")
        files = record_model_episodes(ctx.model, ctx.params, folder, 1, self.deterministic,
                                      state.device, seed=state.seed, name_prefix=f"epoch_{state.epoch}")
        self.files.extend(files)
        if ctx.params.config.print_stats:
            log.info(f"video at epoch {state.epoch}: {', '.join(files)}")
