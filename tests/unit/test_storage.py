"""RolloutStorage with Dict observations kept per key: each key's buffer in its own dtype, minibatches
(flat and sequence) carrying every key."""

import gymnasium as gym
import numpy as np
import torch

from rlchain.algos.core.storage import RolloutStorage, obs_buffer_layout, rollout_step_bytes
from rlchain.envs.obs_dict import ObsDict

SPACE = gym.spaces.Dict({"image": gym.spaces.Box(0, 255, (3, 84, 84), np.uint8),
                         "proprio": gym.spaces.Box(-np.inf, np.inf, (30,), np.float32)})
ACT = gym.spaces.Box(-1, 1, (2,), np.float32)


def _storage(horizon=4, envs=3, states=()):
    return RolloutStorage(horizon, envs, *obs_buffer_layout(SPACE), (2,), torch.float32, 4, 1,
                          torch.device("cpu"), state_shapes=states)


def _fill(storage):
    for t in range(storage.horizon):
        obs = ObsDict({"image": torch.full((storage.num_envs, 3, 84, 84), t, dtype=torch.uint8),
                       "proprio": torch.full((storage.num_envs, 30), float(t))})
        storage.add(t, obs, torch.zeros(storage.num_envs, 2), torch.zeros(storage.num_envs),
                    torch.zeros(storage.num_envs, 1), torch.zeros(storage.num_envs, 4),
                    states=tuple(torch.zeros(1, storage.num_envs, 8) for _ in storage.states),
                    resets=torch.zeros(storage.num_envs, dtype=torch.bool))
        storage.add_outcome(t, torch.zeros(storage.num_envs, 1), torch.zeros(storage.num_envs, dtype=torch.bool),
                            torch.zeros(storage.num_envs, dtype=torch.bool))


def test_rollout_image_memory_is_uint8():
    storage = _storage()
    image = storage.obs["image"]
    assert image.dtype == torch.uint8 and image.shape == (4, 3, 3, 84, 84)
    assert image.element_size() * image[0, 0].numel() == 3 * 84 * 84  # one byte per pixel per step
    assert storage.obs["proprio"].dtype == torch.float32
    # the memory estimate a run checks before building the storage counts the image as bytes too
    assert rollout_step_bytes(SPACE, ACT, 1) < 3 * 84 * 84 + 4 * 30 + 200


def test_flat_minibatches_carry_every_key_in_its_dtype():
    storage = _storage()
    _fill(storage)
    batches = list(storage.minibatches(6, torch.zeros(4, 3)))
    assert len(batches) == 2
    obs = batches[0].obs
    assert isinstance(obs, ObsDict) and obs["image"].dtype == torch.uint8 and obs["image"].shape == (6, 3, 84, 84)
    t = batches[0].index // 3  # each row's step: the image and the vector came from the same one
    assert torch.equal(obs["image"][:, 0, 0, 0].long(), t) and torch.equal(obs["proprio"][:, 0].long(), t)


def test_sequence_minibatches_keep_steps_in_order():
    storage = _storage(states=((1, 3, 8),))
    _fill(storage)
    batch = next(storage.sequence_minibatches(4, 2, torch.zeros(4, 3), shuffle=False))
    assert batch.obs["image"][:, 0, 0, 0].tolist() == [0, 1, 2, 3]  # env 0's two sequences of 2 steps
