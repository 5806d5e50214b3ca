"""The camera task's multi_input config trains a couple of epochs with the image stored as uint8, plays
back, and resumes bit-identically (the next observations, an ObsDict, saved in the checkpoint); a gymnasium
Dict env trains through rlchain.PPO('MultiInputPolicy', env) and, through a YAML, resumes bit-identically
too (its sub-envs' state, the per-key normalizer, the carried observation dict with a Discrete key)."""

import logging
import os

import gymnasium as gym
import numpy as np
import pytest
import torch

import rlchain
from rlchain import Runner
from rlchain.training.events import Callback
from tests.conftest import CONFIGS
from tests.smoke.dict_envs import ImageSide
from tests.smoke.test_exact_resume import check_split

pytestmark = pytest.mark.smoke
CONFIG = os.path.join(CONFIGS, "ppo_camera_reach.yaml")
SMALL = ["params.config.num_actors=8", "params.config.minibatch_size=100", "params.config.mini_epochs=1"]


def test_camera_config_trains_with_uint8_images_and_plays(tmp_path):
    seen = []

    class Storage(Callback):
        def on_epoch_end(self, ctx, stats, episodes):
            obs = ctx.algorithm.storage.obs
            seen.append((obs["image"].dtype, obs["image"].shape, obs["proprio"].dtype))

    over = [*SMALL, "params.config.max_epochs=2", f"params.config.train_dir={tmp_path}/runs",
            "params.config.print_stats=false"]
    result = Runner().load(CONFIG, over).train(callbacks=[Storage()])
    assert result.epoch == 2
    assert seen[-1] == (torch.uint8, (25, 8, 1, 24, 24), torch.float32)
    last = os.path.join(result.run_dir, "nn", "last_camera_reach.pth")
    played = Runner().load(CONFIG, ["params.config.player.games_num=4"]).play(last, games=4, quiet=True)
    assert played.games == 4 and played.mean_length == 25


def test_camera_config_resume_is_bit_identical(tmp_path):
    check_split(tmp_path, "ppo_camera_reach.yaml", SMALL, 2)


class ImageSideRoom(ImageSide):
    """ImageSide with a Discrete key beside the image and the vector: the step count modulo 3 (start 1)."""

    def __init__(self):
        super().__init__()
        self.observation_space = gym.spaces.Dict({**self.observation_space.spaces,
                                                  "room": gym.spaces.Discrete(3, start=1)})

    def _obs(self):
        return {**super()._obs(), "room": 1 + self.t % 3}


def test_gymnasium_dict_env_multi_input_resume_is_bit_identical(tmp_path, caplog):
    if "ImageSideRoomTest-v0" not in gym.registry:
        gym.register("ImageSideRoomTest-v0", entry_point=ImageSideRoom)
    over = ["params.config.env_name=ImageSideRoomTest-v0", "params.config.vecenv_type=sync",
            "params.network.name=multi_input", "params.network.mlp.units=[16]", "params.config.num_actors=2",
            "params.config.horizon_length=16", "params.config.minibatch_size=32", "params.config.normalize_input=true"]
    with caplog.at_level(logging.WARNING, logger="rlchain"):
        half = check_split(tmp_path, "ppo_cartpole.yaml", over, 2)
    position = half["run_state"]["position"]["obs"]
    assert half["run_state"]["env"] is not None and set(position) == {"image", "room", "vec"}
    assert position["room"].dtype == torch.int64 and position["image"].dtype == torch.uint8
    assert not [r for r in caplog.records if r.getMessage().startswith(("resume:", "warning:"))]


def test_sb3_multi_input_policy_trains_on_a_gymnasium_dict_env(tmp_path):
    model = rlchain.PPO("MultiInputPolicy", ImageSide, n_envs=4, n_steps=64, learning_rate=1e-3, seed=0, verbose=0,
                        tensorboard_log=str(tmp_path))
    model.learn(2048)  # 8 updates; seeds 0-4 all play 40/40 after them (6000 before)
    env = ImageSide()
    obs, _ = env.reset(seed=1)
    hits = 0
    for _ in range(40):
        action, _ = model.predict(obs)
        obs, reward, *_ = env.step(action)
        hits += reward
    assert hits >= 36  # random: 20
    path = model.save(str(tmp_path / "mi"))
    loaded = rlchain.PPO.load(path)
    assert loaded.policy_name == "MultiInputPolicy"
    batch = {k: np.stack([v, v]) for k, v in obs.items()}
    assert np.array_equal(loaded.predict(batch)[0], model.predict(batch)[0])
