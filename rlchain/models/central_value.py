"""The asymmetric critic: a value-only network on the env's full ``state`` (``central_value_config``):
the built-in ``actor_critic`` trunk with a value head, or a registered network (rl_games' contract)."""

from __future__ import annotations

import gymnasium as gym
import torch
import torch.nn as nn

from rlchain.config.network import NetworkConfig
from rlchain.errors import NetworkError
from rlchain.models.base import ValueModel, value_normalizer
from rlchain.models.normalization import obs_normalizer
from rlchain.networks.actor_critic import Trunk
from rlchain.networks.layers import activation, linear
from rlchain.networks.multi_input import MultiInputEncoder


class CentralValueNetwork(nn.Module):
    """state (B, *state_shape) -> value (B, value_size): a trunk (cnn, mlp) and a linear value head."""

    def __init__(self, cfg: NetworkConfig, state_shape: tuple[int, ...] | gym.spaces.Dict, value_size: int) -> None:
        super().__init__()
        if isinstance(state_shape, gym.spaces.Dict):  # multi_input: its own encoder per key it reads
            encoder = MultiInputEncoder(state_shape, cfg.inputs, "params.config.central_value_config.network")
            self.trunk = Trunk(cfg, (), encoder=encoder)
        else:
            self.trunk = Trunk(cfg, state_shape)
        self.value = linear(self.trunk.out_size, value_size, cfg.mlp.initializer)
        self.value_act = activation(cfg.value_activation)

    def forward(self, state: torch.Tensor, states: tuple = (), resets: torch.Tensor | None = None,
                seq_length: int = 1) -> tuple[torch.Tensor, tuple]:
        """-> (values, new RNN states); with an RNN, rows come in seq_length blocks (RecurrentLayer)."""
        features, new_states = self.trunk(state, states, resets, seq_length)
        return self.value_act(self.value(features)), new_states

    @property
    def is_rnn(self) -> bool:
        return self.trunk.rnn is not None

    def initial_state(self, batch: int, device: torch.device) -> tuple[torch.Tensor, ...]:
        return tuple(self.trunk.initial_state(batch, device))


class RegisteredCriticNetwork(nn.Module):
    """A registered network as the critic, rl_games' contract: built from a block with
    ``central_value: True``, its ``forward({'obs': state})`` returns ``(value (B, value_size), states)``.
    Feedforward only (a recurrent critic: ``actor_critic`` with an ``rnn`` block)."""

    is_rnn = False

    def __init__(self, network: nn.Module, value_size: int) -> None:
        super().__init__()
        if callable(getattr(network, "is_rnn", None)) and network.is_rnn():
            raise ValueError("a registered recurrent critic network is not supported; use actor_critic with "
                             "an rnn block")
        self.net = network
        self.value_size = value_size

    def initial_state(self, batch: int, device: torch.device) -> tuple[torch.Tensor, ...]:
        return ()

    def forward(self, state: torch.Tensor, states: tuple = (), resets: torch.Tensor | None = None,
                seq_length: int = 1) -> tuple[torch.Tensor, tuple]:
        out = self.net({"obs": state})
        if not isinstance(out, (tuple, list)) or len(out) != 2:
            got = f"{len(out)} outputs" if isinstance(out, (tuple, list)) else type(out).__name__
            raise NetworkError(f"central value network {type(self.net).__name__} returned {got}; a critic returns "
                               f"(value, states): build it with central_value: True")
        value = out[0]
        if not isinstance(value, torch.Tensor) or tuple(value.shape) != (state.shape[0], self.value_size):
            shape = tuple(value.shape) if isinstance(value, torch.Tensor) else type(value).__name__
            raise NetworkError(f"central value network {type(self.net).__name__} returned values of shape {shape}, "
                               f"expected ({state.shape[0]}, {self.value_size})")
        return value, ()


class CentralValue(ValueModel):
    """Critic model: state normalization, the network, and value normalization (raw <-> normalized)."""

    def __init__(self, cfg: NetworkConfig | None, state_shape: tuple[int, ...], value_size: int,
                 normalize_input: bool, normalize_value: bool, network: nn.Module | None = None,
                 value_normalizer_kind: str = "rl_games", obs_normalizer_kind: str = "rl_games",
                 obs_normalizer_exclude: tuple[str, ...] = (),
                 obs_slice: slice | tuple[int, ...] | None = None) -> None:
        """The built-in critic from ``cfg``, or ``network``: a registered one (cfg None). ``obs_slice``: the
        critic's part of the env's flat observations (its ``obs_groups.critic`` view, the state part)."""
        super().__init__()
        self.obs_slice = obs_slice
        self.network = CentralValueNetwork(cfg, state_shape, value_size) if network is None \
            else RegisteredCriticNetwork(network, value_size)
        self.obs_norm = obs_normalizer(state_shape, obs_normalizer_kind, obs_normalizer_exclude) \
            if normalize_input else None
        self.value_norm = value_normalizer(value_size, normalize_value, value_normalizer_kind)
        self.fold_values = value_normalizer_kind == "rl_games"

    @property
    def is_rnn(self) -> bool:
        return self.network.is_rnn

    def initial_state(self, batch: int, device: torch.device | None = None) -> tuple[torch.Tensor, ...]:
        """Zero RNN states for ``batch`` envs (empty without an RNN)."""
        if not self.is_rnn:
            return ()
        return self.network.initial_state(batch, device or self.network.value.weight.device)

    def forward(self, state: torch.Tensor, states: tuple = (), resets: torch.Tensor | None = None,
                seq_length: int = 1) -> tuple[torch.Tensor, tuple]:
        """Values in the normalized space (B, value_size) and the new RNN states."""
        if self.is_rnn and not states:
            states = self.initial_state(state.shape[0] // seq_length, state.device)
        return self.network(self.preprocess(state), tuple(states), resets, seq_length)

    @torch.inference_mode()
    def step(self, state: torch.Tensor, states: tuple = ()) -> tuple[torch.Tensor, tuple]:
        """One rollout step: raw-scale values (B, value_size) and the RNN states after it."""
        values, new_states = self(state, states)
        return self.denorm_value(values), new_states

    def value(self, state: torch.Tensor, states: tuple = ()) -> torch.Tensor:
        """Raw-scale values (B, value_size) for the rollout and GAE."""
        return self.step(state, states)[0]
