"""Networks written the way rl_games users write them, registered through rl_games' ``model_builder``.

- ``recon_head``: an ``A2CBuilder`` subclass whose ``Network`` extends ``A2CBuilder.Network`` with a head
  reconstructing the observation from ``actor_mlp``'s features, trained by an auxiliary loss.
- ``small_base``: a ``NetworkBuilder.BaseNetwork`` subclass built with its helpers (``_build_mlp``,
  ``activations_factory``, ``init_factory``, ``_calc_input_size``).
- ``lambda_a2c``: HOW_TO's registration, ``register_network(name, lambda **kwargs: A2CBuilder())``.
- ``plain_module``: a builder whose ``build`` returns a plain ``nn.Module`` (no ``is_rnn``, no ``get_aux_loss``).
- ``rlg_sac``: rl_games' ``SACBuilder`` (actor returning a tanh-squashed Normal, twin critics of (B, 1)).
"""

import torch
import torch.nn as nn
import torch.nn.functional as F

from rlchain.rl_games.algos_torch import model_builder, network_builder


class ReconHeadBuilder(network_builder.A2CBuilder):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)

    class Network(network_builder.A2CBuilder.Network):
        def __init__(self, params, **kwargs):
            super().__init__(params, **kwargs)
            assert not self.is_rnn() and not self.separate and isinstance(self.actor_mlp, nn.Sequential)
            obs_size = self._calc_input_size(kwargs["input_shape"])
            self.recon = self._build_mlp(self.units[-1], [obs_size], "None", nn.Linear)
            self.recon_loss = None
            self.seen_prev_actions = False

        def forward(self, obs_dict):
            out = super().forward(obs_dict)
            if obs_dict.get("is_train", False):
                self.seen_prev_actions = obs_dict.get("prev_actions") is not None
                obs = obs_dict["obs"]
                self.recon_loss = F.mse_loss(self.recon(self.actor_mlp(obs)), obs)
            return out

        def get_aux_loss(self):
            return {"recon_loss": self.recon_loss} if self.recon_loss is not None else None

    def build(self, name, **kwargs):
        return ReconHeadBuilder.Network(self.params, **kwargs)


class SmallBaseNet(network_builder.NetworkBuilder.BaseNetwork):
    def __init__(self, params, **kwargs):
        super().__init__()
        actions_num = kwargs.pop("actions_num")
        input_size = self._calc_input_size(kwargs.pop("input_shape"))
        units = params["mlp"]["units"]
        self.body = self._build_mlp(input_size, units, params["mlp"]["activation"], nn.Linear)
        self.mu = nn.Linear(units[-1], actions_num)
        self.sigma = nn.Parameter(torch.zeros(actions_num))
        self.value = nn.Linear(units[-1], kwargs.pop("value_size", 1))
        init = self.init_factory.create(**params["mlp"]["initializer"])
        for module in self.modules():
            if isinstance(module, nn.Linear):
                init(module.weight)
        self.value_act = self.activations_factory.create("None")

    def forward(self, obs_dict):
        h = self.body(obs_dict["obs"])
        mu = self.mu(h)
        return mu, mu * 0 + self.sigma, self.value_act(self.value(h)), None


class SmallBaseBuilder(network_builder.NetworkBuilder):
    def load(self, params):
        self.params = params

    def build(self, name, **kwargs):
        return SmallBaseNet(self.params, **kwargs)


class PlainModule(nn.Module):
    def __init__(self, n_in, actions_num):
        super().__init__()
        self.body = nn.Sequential(nn.Linear(n_in, 32), nn.Tanh())
        self.logits = nn.Linear(32, actions_num)
        self.value = nn.Linear(32, 1)

    def forward(self, obs_dict):
        h = self.body(obs_dict["obs"])
        return self.logits(h), self.value(h), None


class PlainBuilder(network_builder.NetworkBuilder):
    def load(self, params):
        self.params = params

    def build(self, name, **kwargs):
        return PlainModule(kwargs["input_shape"][0], kwargs["actions_num"])


model_builder.register_network("recon_head", ReconHeadBuilder)
model_builder.register_network("small_base", SmallBaseBuilder)
model_builder.register_network("lambda_a2c", lambda **kwargs: network_builder.A2CBuilder())
model_builder.register_network("plain_module", PlainBuilder)
model_builder.register_network("rlg_sac", network_builder.SACBuilder)
