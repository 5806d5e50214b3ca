"""A user network builder without config_class: keys of its block that it never read are a warning that
names them (rlchain/networks/base.py ReadKeys), so a typo in a custom network's block is not silent."""

import copy
import pickle
import warnings

import pytest
import torch.nn as nn

from rlchain.networks.base import NetworkBuilder, ReadKeys, instantiate


class UnitsBuilder(NetworkBuilder):
    """Reads mlp.units and activation, nothing else."""

    def build(self, name, **kwargs):
        units = self.params["mlp"]["units"]
        self.params.get("activation", "relu")
        return nn.Linear(kwargs["input_shape"][0], units[0])


def test_unread_keys_are_one_warning_naming_each_path():
    block = {"name": "units_net", "activation": "elu", "mlp": {"units": [8], "unitz": [4]}, "separat": True}
    with pytest.warns(UserWarning) as caught:
        net = instantiate(UnitsBuilder, block, input_shape=(3,))
    assert isinstance(net, nn.Linear) and len(caught) == 1
    message = str(caught[0].message)
    assert message.startswith("params.network: mlp.unitz, separat not read by network builder 'units_net'")
    assert "\n" not in message


def test_a_builder_that_reads_everything_or_forwards_the_block_is_not_blamed():
    def forwards(params, **kwargs):  # e.g. builds a dataclass from the whole block
        dict(params)
        return nn.Identity()

    def reads_nested_copy(params, **kwargs):
        {**params["mlp"]}
        return nn.Identity()

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        instantiate(forwards, {"name": "f", "mlp": {"units": [1]}, "extra": 1})
        instantiate(reads_nested_copy, {"name": "f", "mlp": {"units": [1], "x": 2}})
        instantiate(UnitsBuilder, {"name": "u", "mlp": {"units": [2]}}, input_shape=(3,))


def test_central_value_key_added_by_rlchain_is_not_reported():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        instantiate(UnitsBuilder, {"name": "u", "central_value": True, "mlp": {"units": [2]}}, input_shape=(3,))


def test_read_keys_block_still_behaves_as_the_dict_it_wraps():
    block = ReadKeys({"a": 1, "mlp": {"units": [2]}})
    assert block == {"a": 1, "mlp": {"units": [2]}} and isinstance(block["mlp"], dict)
    assert copy.deepcopy(block) == block and pickle.loads(pickle.dumps(block)) == block
    assert block.unread() == []  # deepcopy and pickle read every key
    fresh = ReadKeys({"a": 1, "mlp": {"units": [2]}})
    fresh["mlp"]
    assert fresh.unread() == ["a", "mlp.units"]
