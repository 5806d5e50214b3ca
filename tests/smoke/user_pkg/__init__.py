"""A user package that registers its own network, as an rl_games user would."""

import torch.nn as nn

from rlchain import model_builder
from rlchain.networks import NetworkBuilder


class TestNet(nn.Module):
    """Two linear layers; returns rl_games' (logits, value, states) tuple."""

    def __init__(self, params, **kwargs):
        super().__init__()
        hidden = int(params.get("hidden", 32))
        n_in = kwargs["input_shape"][0]
        self.body = nn.Sequential(nn.Linear(n_in, hidden), nn.Tanh())
        self.logits = nn.Linear(hidden, kwargs["actions_num"])
        self.value = nn.Linear(hidden, kwargs.get("value_size", 1))
        self.calls = 0

    def forward(self, input_dict):
        self.calls += 1
        h = self.body(input_dict["obs"])
        return self.logits(h), self.value(h), None


class TestNetBuilder(NetworkBuilder):
    def build(self, name, **kwargs):
        return TestNet(self.params, **kwargs)


model_builder.register_network("testnet", TestNetBuilder)


class BadAuxNet(TestNet):
    """An auxiliary loss left unreduced: one value per sample instead of a scalar."""

    def forward(self, input_dict):
        logits, value, states = super().forward(input_dict)
        self.per_sample = value.squeeze(-1).square()
        return logits, value, states

    def get_aux_loss(self):
        return {"value_l2": self.per_sample}


class BadAuxNetBuilder(NetworkBuilder):
    def build(self, name, **kwargs):
        return BadAuxNet(self.params, **kwargs)


model_builder.register_network("bad_aux_net", BadAuxNetBuilder)

