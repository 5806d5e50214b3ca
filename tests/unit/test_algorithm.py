"""rlchain/algos/base/algorithm.py: a saved position (the observations the next epoch acts on) round-trips
through a checkpoint's plain data types, Dict observations kept per key coming back as an ObsDict."""

import torch

from rlchain.algos.base.algorithm import position_copy, position_on
from rlchain.envs.obs_dict import ObsDict


def test_per_key_observations_are_saved_as_a_plain_dict_and_come_back_as_an_obs_dict():
    obs = ObsDict({"image": torch.zeros(2, 1, 4, 4, dtype=torch.uint8), "proprio": torch.ones(2, 3)})
    saved = position_copy(obs)
    assert type(saved) is dict and saved["proprio"] is not obs["proprio"]
    back = position_on(saved, torch.device("cpu"))
    assert isinstance(back, ObsDict) and back.shape == (2,) and back["image"].dtype == torch.uint8
    assert torch.equal(back["proprio"], obs["proprio"])


def test_flat_observations_and_rnn_states_come_back_as_they_were():
    flat = torch.arange(6.0).reshape(2, 3)
    assert torch.equal(position_on(position_copy(flat), torch.device("cpu")), flat)
    states = position_on(position_copy((torch.zeros(1, 2, 4), torch.ones(1, 2, 4))), torch.device("cpu"))
    assert type(states) is tuple and torch.equal(states[1], torch.ones(1, 2, 4))
