"""SAC and DQN with the multi_input network on Dict observations: a couple of epochs with the image stored as
uint8 in the replay buffer (a Discrete key as int64), play, resume with the replay buffer saved bit-identical to a
straight run (SAC on the tensor camera env, DQN on a gymnasium Dict env); SB3's SAC / DQN
("MultiInputPolicy", env) on a gymnasium Dict env; a flat network on a Dict env keeps the flat float32 buffer;
hindsight replay with multi_input is a one-line error."""

import gymnasium as gym
import numpy as np
import pytest
import torch
import yaml

import rlchain
from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.training.events import Callback
from tests.smoke.dict_envs import ImageSideStep
from tests.smoke.test_exact_resume import check_split, last

pytestmark = pytest.mark.smoke

SAC_CAMERA = {"params": {
    "seed": 5, "algo": {"name": "sac"}, "model": {"name": "soft_actor_critic"},
    "network": {"name": "multi_input", "inputs": {"image": {"encoder": "cnn", "units": [16]},
                                                  "proprio": {"encoder": "mlp", "units": [16]}},
                "mlp": {"units": [32], "activation": "relu"}},
    "config": {"name": "camera_sac", "env_name": "TorchCameraReach-v0",
               "env_config": {"device": "cpu", "image_size": 16}, "device": "cpu", "normalize_input": True,
               "num_actors": 4, "num_steps_per_episode": 8, "batch_size": 16, "num_warmup_frames": 16,
               "replay_buffer_size": 256, "save_replay_buffer": True, "player": {"games_num": 2}}}}


class ImageSideBox(ImageSideStep):
    """ImageSideStep with a Box action (-1 or 1 names the side): for SAC."""

    def __init__(self):
        super().__init__()
        self.action_space = gym.spaces.Box(-1, 1, (1,), np.float32)

    def step(self, action):
        return super().step(int(float(np.asarray(action).reshape(-1)[0]) > 0))


gym.register("ImageSideDictTest-v0", entry_point=ImageSideStep)
gym.register("ImageSideBoxDictTest-v0", entry_point=ImageSideBox)

DQN_DICT = {"params": {
    "seed": 5, "algo": {"name": "dqn"}, "model": {"name": "dqn"},
    "network": {"name": "multi_input", "mlp": {"units": [16], "activation": "relu"},
                "inputs": {"image": {"encoder": "cnn", "units": [16]}}},
    "config": {"name": "side_dqn", "env_name": "ImageSideDictTest-v0", "device": "cpu", "normalize_input": True,
               "num_actors": 2, "num_steps_per_episode": 8, "batch_size": 8, "num_warmup_frames": 8,
               "replay_buffer_size": 128, "n_step": 2, "save_replay_buffer": True, "player": {"games_num": 2}}}}


class Replay(Callback):
    def __init__(self):
        self.buffer = None

    def on_epoch_end(self, ctx, stats, episodes):
        self.buffer = ctx.algorithm.buffer


def write(tmp_path, config):
    path = tmp_path / f"{config['params']['config']['name']}.yaml"
    path.write_text(yaml.safe_dump(config))
    return str(path)


@pytest.mark.parametrize("config, image_shape", [(SAC_CAMERA, (1, 16, 16)), (DQN_DICT, (8, 8, 3))],
                         ids=["sac_camera", "dqn_gymnasium_dict"])
def test_trains_with_uint8_images_in_the_replay_buffer_and_plays(tmp_path, config, image_shape):
    path = write(tmp_path, config)
    replay = Replay()
    over = ["params.config.max_epochs=2", f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
            "params.torch_threads=1"]
    result = Runner().load(path, over).train(callbacks=[replay])
    assert result.epoch == 2
    buffer = replay.buffer
    assert buffer.obs["image"].dtype == torch.uint8 and buffer.next_obs["image"].dtype == torch.uint8
    assert tuple(buffer.obs["image"].shape[1:]) == image_shape
    assert buffer.obs["image"][:len(buffer)].max() > 0  # real frames, not the zero fill
    played = Runner().load(path, ["params.torch_threads=1"]).play(last(result), games=2, quiet=True)
    assert played.games == 2


def test_sac_camera_resume_with_the_replay_buffer_is_bit_identical(tmp_path):
    half = check_split(tmp_path, write(tmp_path, SAC_CAMERA), [], 1)
    assert half["replay_buffer"]["obs"]["image"].dtype == torch.uint8


def test_dqn_resume_on_a_gymnasium_dict_env_is_bit_identical(tmp_path):
    half = check_split(tmp_path, write(tmp_path, DQN_DICT), [], 1)
    buffer = half["replay_buffer"]
    assert buffer["obs"]["image"].dtype == torch.uint8 and buffer["next_obs"]["step"].dtype == torch.int64


def test_a_flat_network_on_a_dict_env_keeps_the_flat_replay_buffer(tmp_path):
    # soft_actor_critic's network is not multi_input: the keys arrive concatenated, stored as one float32 vector
    config = {"params": {**SAC_CAMERA["params"], "network": {"name": "soft_actor_critic", "mlp": {"units": [16]}},
                         "config": {**SAC_CAMERA["params"]["config"], "env_name": "ImageSideBoxDictTest-v0",
                                    "env_config": {}, "num_actors": 2, "max_epochs": 1, "print_stats": False,
                                    "train_dir": str(tmp_path)}}}
    replay = Replay()
    Runner().load(config).train(callbacks=[replay])
    obs = replay.buffer.obs
    assert isinstance(obs, torch.Tensor) and obs.dtype == torch.float32
    assert obs.shape[1:] == (gym.spaces.flatdim(ImageSideStep().observation_space),)  # gymnasium's flat layout


def test_sac_with_multi_input_on_discrete_actions_trains_and_plays(tmp_path):
    # the categorical actor and the per-action twin critics each read the keys through an encoder of their own
    network = {"name": "multi_input", "inputs": {"image": {"encoder": "cnn", "units": [16]}},
               "mlp": {"units": [16], "activation": "relu"}}
    config = {"params": {**SAC_CAMERA["params"], "network": network,
                         "config": {**SAC_CAMERA["params"]["config"], "env_name": "ImageSideDictTest-v0",
                                    "env_config": {}, "num_actors": 2, "max_epochs": 2, "print_stats": False,
                                    "save_replay_buffer": False, "train_dir": str(tmp_path)}}}
    result = Runner().load(config).train()
    assert result.epoch == 2
    played = Runner().load(config).play(f"{result.run_dir}/nn/last_camera_sac.pth", games=1, quiet=True)
    assert played.games == 1


def test_hindsight_replay_with_multi_input_is_a_one_line_error(tmp_path):
    config = {"params": {**SAC_CAMERA["params"], "network": {"name": "multi_input", "mlp": {"units": [16]}},
                         "config": {**SAC_CAMERA["params"]["config"], "env_name": "ImageSideBoxDictTest-v0",
                                    "env_config": {}, "num_actors": 1, "replay": {"her": {}},
                                    "train_dir": str(tmp_path)}}}
    with pytest.raises(ConfigError) as err:
        Runner().load(config).train()
    assert "params.config.replay.her" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("cls, env", [(rlchain.SAC, ImageSideBox), (rlchain.DQN, ImageSideStep)], ids=["sac", "dqn"])
def test_sb3_multi_input_policy_off_policy(tmp_path, cls, env):
    model = cls("MultiInputPolicy", env, n_envs=2, learning_starts=16, batch_size=16, buffer_size=256, seed=0,
                num_steps_per_episode=16, verbose=0, policy_kwargs={"net_arch": [16]}, tensorboard_log=str(tmp_path))
    model.learn(64)
    obs, _ = env().reset(seed=1)
    action, _ = model.predict(obs, deterministic=True)
    assert env().action_space.contains(np.asarray(action, dtype=env().action_space.dtype).reshape(
        env().action_space.shape))
    model.save(tmp_path / "model")
    again = cls.load(tmp_path / "model", env=env)
    assert np.allclose(again.predict(obs, deterministic=True)[0], action)
    model.save_replay_buffer(tmp_path / "replay")  # per key, read back as data
    again.load_replay_buffer(tmp_path / "replay")
    assert again.replay_buffer.size() == model.replay_buffer.size() > 0
    assert again.replay_buffer.state["obs"]["image"].dtype == torch.uint8
