"""ObsDict: Dict observations kept per key, with the batch operations the rollout and storage use."""

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.envs.obs_dict import ObsDict, as_obs_dict, dict_zeros, is_dict_space

SPACE = gym.spaces.Dict({"image": gym.spaces.Box(0, 255, (1, 4, 4), np.uint8),
                         "proprio": gym.spaces.Box(-np.inf, np.inf, (3,), np.float32)})


def _batch(n=5):
    return ObsDict({"image": torch.randint(0, 255, (n, 1, 4, 4), dtype=torch.uint8),
                    "proprio": torch.randn(n, 3)})


def test_shape_is_the_batch_shape_and_keys_keep_their_dtype():
    obs = _batch()
    assert obs.shape == (5,) and obs.dim() == 1
    assert obs["image"].dtype == torch.uint8 and obs["proprio"].dtype == torch.float32
    assert list(obs) == ["image", "proprio"]


def test_row_indexing_and_assignment_act_on_every_key():
    obs = _batch()
    rows = obs[1:3]
    assert isinstance(rows, ObsDict) and rows.shape == (2,)
    assert torch.equal(rows["proprio"], obs["proprio"][1:3])
    picked = obs[torch.tensor([0, 4])]
    assert torch.equal(picked["image"], obs["image"][[0, 4]])
    target = obs.clone()
    target[torch.tensor([1, 2])] = _batch(2)
    assert not torch.equal(target["proprio"][1:3], obs["proprio"][1:3])
    assert torch.equal(target["proprio"][0], obs["proprio"][0])  # clone: the original is untouched


def test_reshape_transpose_index_select_over_batch_dims():
    storage = dict_zeros((4, 3), SPACE)
    assert storage.shape == (4, 3) and storage["image"].shape == (4, 3, 1, 4, 4)
    flat = storage.reshape(-1, *storage.shape[2:])  # as the trainer flattens a rollout
    assert flat.shape == (12,) and flat["image"].shape == (12, 1, 4, 4)
    seq = storage.reshape(2, 2, 3).transpose(1, 2).reshape(12)
    assert seq.shape == (12,) and seq["proprio"].shape == (12, 3)
    assert flat.index_select(0, torch.tensor([0, 5]))["image"].shape == (2, 1, 4, 4)
    with pytest.raises(IndexError):
        flat.index_select(1, torch.tensor([0]))


def test_flatten_concatenates_keys_as_float():
    obs = _batch(2)
    flat = obs.flatten(1)
    assert flat.shape == (2, 16 + 3) and flat.dtype == torch.float32


def test_as_obs_dict_casts_each_key_to_its_space_dtype():
    raw = {"proprio": np.zeros((2, 3), np.float64), "image": np.ones((2, 1, 4, 4), np.uint8)}
    obs = as_obs_dict(raw, SPACE, "cpu")
    assert list(obs) == ["image", "proprio"]  # the space's order
    assert obs["proprio"].dtype == torch.float32 and obs["image"].dtype == torch.uint8


def test_is_dict_space_leaves_out_the_central_value_layout():
    assert is_dict_space(SPACE)
    box = gym.spaces.Box(-1, 1, (2,), np.float32)
    assert not is_dict_space(gym.spaces.Dict({"obs": box, "state": box}))
    assert not is_dict_space(box)
