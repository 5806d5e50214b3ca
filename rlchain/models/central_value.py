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
from rlchain.networks.actor_critic import ActorCriticNetwork
from rlchain.networks.multi_input import MultiInputEncoder


def critic_network(cfg: NetworkConfig, state_shape: tuple[int, ...] | gym.spaces.Dict,
                   value_size: int) -> ActorCriticNetwork:
    """The built-in critic: state (B, *state_shape) -> (value (B, value_size), states), the actor-critic network
    built as a critic (a trunk and the value head: rl_games' central value network and its names)."""
    if isinstance(state_shape, gym.spaces.Dict):  # multi_input: its own encoder per key it reads
        def encoder() -> MultiInputEncoder:
            return MultiInputEncoder(state_shape, cfg.inputs, "params.config.central_value_config.network")
        return ActorCriticNetwork(cfg, (), value_size, value_size, False, encoder, central_value=True)
    return ActorCriticNetwork(cfg, state_shape, value_size, value_size, False, central_value=True)


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
        if network is not None and callable(getattr(network, "is_rnn", None)) and network.is_rnn():
            raise ValueError("a registered recurrent critic network is not supported; use actor_critic with "
                             "an rnn block")
        network = critic_network(cfg, state_shape, value_size) if network is None else network
        self.value_size = value_size
        # rl_games' model: its normalizers, then the network (the state dict in rl_games' order)
        self.value_mean_std = value_normalizer(value_size, normalize_value, value_normalizer_kind)
        self.running_mean_std = obs_normalizer(state_shape, obs_normalizer_kind, obs_normalizer_exclude) \
            if normalize_input else None
        self.a2c_network = network
        self.fold_values = value_normalizer_kind == "rl_games"

    @property
    def is_rnn(self) -> bool:
        return isinstance(self.a2c_network, ActorCriticNetwork) and self.a2c_network.is_rnn()

    def initial_state(self, batch: int, device: torch.device | None = None) -> tuple[torch.Tensor, ...]:
        """Zero RNN states for ``batch`` envs (empty without an RNN)."""
        if not self.is_rnn:
            return ()
        return self.a2c_network.get_default_rnn_state(batch, device)

    def forward(self, state: torch.Tensor, states: tuple = (), resets: torch.Tensor | None = None,
                seq_length: int = 1) -> tuple[torch.Tensor, tuple]:
        """Values in the normalized space (B, value_size) and the new RNN states; with an RNN, rows come in
        seq_length blocks (see RecurrentLayer)."""
        inputs: dict = {"obs": self.preprocess(state)}
        if self.is_rnn:
            states = tuple(states) or self.initial_state(state.shape[0] // seq_length, state.device)
            inputs.update(rnn_states=states, dones=resets, seq_length=seq_length)
        out = self.a2c_network(inputs)
        if isinstance(self.a2c_network, ActorCriticNetwork):
            return out[0], tuple(out[1] or ())
        return _checked_value(self.a2c_network, out, state.shape[0], self.value_size), ()

    @torch.inference_mode()
    def step(self, state: torch.Tensor, states: tuple = ()) -> tuple[torch.Tensor, tuple]:
        """One rollout step: raw-scale values (B, value_size) and the RNN states after it."""
        values, new_states = self(state, states)
        return self.denorm_value(values), new_states

    def value(self, state: torch.Tensor, states: tuple = ()) -> torch.Tensor:
        """Raw-scale values (B, value_size) for the rollout and GAE."""
        return self.step(state, states)[0]


def _checked_value(network: nn.Module, out: object, rows: int, value_size: int) -> torch.Tensor:
    """The values (rows, value_size) a registered critic network returned, rl_games' contract: built from a block
    with ``central_value: True``, its ``forward({'obs': state})`` returns ``(value, states)``."""
    if not isinstance(out, (tuple, list)) or len(out) != 2:
        got = f"{len(out)} outputs" if isinstance(out, (tuple, list)) else type(out).__name__
        raise NetworkError(f"central value network {type(network).__name__} returned {got}; a critic returns "
                           f"(value, states): build it with central_value: True")
    value = out[0]
    if not isinstance(value, torch.Tensor) or tuple(value.shape) != (rows, value_size):
        shape = tuple(value.shape) if isinstance(value, torch.Tensor) else type(value).__name__
        raise NetworkError(f"central value network {type(network).__name__} returned values of shape {shape}, "
                           f"expected ({rows}, {value_size})")
    return value
