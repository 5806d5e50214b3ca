"""Video recording (rlchain.inference.video): mp4 files from a checkpoint and from in-training evaluations."""

import os

import pytest

from rlchain.config.errors import ConfigError
from rlchain.inference.video import record_episodes
from rlchain.runner import Runner
from rlchain.training.video_callback import VideoCallback
from tests.conftest import CONFIGS, ROOT, installed

# a mark, not pytest.importorskip: that imports moviepy when the file is collected, in every pytest process
# (rlchain[video]: moviepy, pygame; the tests import them when they record)
pytestmark = installed("moviepy", "pygame")

CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")


def test_record_cartpole_checkpoint(tmp_path):
    params = Runner().load(CARTPOLE, ["params.config.env_config={max_episode_steps: 60}"]).params
    files = record_episodes(params, os.path.join(ROOT, "nn", "cartpole.pth"), str(tmp_path / "videos"), games=2)
    assert len(files) == 2
    for path in files:
        assert path.endswith(".mp4") and os.path.getsize(path) > 0
    # recorded again into the same folder: the same names, overwritten, are what it wrote
    again = record_episodes(params, os.path.join(ROOT, "nn", "cartpole.pth"), str(tmp_path / "videos"), games=2)
    assert again == files


def test_video_callback_records_during_training(tmp_path):
    runner = Runner().load(CARTPOLE, [
        "params.config.max_epochs=4", "params.config.print_stats=false", f"params.config.train_dir={tmp_path}",
        "params.config.evaluation={interval: 2, games: 1}", "params.config.env_config={max_episode_steps: 30}"])
    callback = VideoCallback(every_n_evaluations=2)
    result = runner.train(callbacks=[callback])
    assert callback.count == 2 and len(callback.files) == 1
    assert callback.files[0].startswith(os.path.join(result.run_dir, "videos", "epoch_4"))
    assert os.path.getsize(callback.files[0]) > 0


def test_non_gymnasium_env_is_a_config_error(tmp_path):
    params = Runner().load(CARTPOLE, ["params.config.env_name=TorchCartPole-v0"]).params
    with pytest.raises(ConfigError, match="video recording needs a gymnasium id env"):
        record_episodes(params, None, str(tmp_path))
