"""rl_games' ``common.layers.recurrent``: LSTM / GRU over (T, N, F) sequences that restart at episode ends.

Both are rlchain's recurrent layer (:class:`rlchain.networks.rnn.RecurrentLayer`, the one the actor-critic
network holds), built from rl_games' arguments: ``forward(input (T, N, F), states, done_masks, bptt_len)``, the
layer held as ``.rnn`` so a state dict reads ``<name>.rnn.weight_ih_l0`` as rl_games' does.
"""

from __future__ import annotations

from rlchain.config.network import RnnConfig
from rlchain.networks.rnn import RecurrentLayer


class LSTMWithDones(RecurrentLayer):
    """``nn.LSTM(input_size, hidden_size, num_layers)`` with episode restarts; states are ``(h, c)``, each
    (layers, N, H)."""

    def __init__(self, input_size: int, hidden_size: int, num_layers: int = 1) -> None:
        super().__init__(input_size, RnnConfig(name="lstm", units=hidden_size, layers=num_layers))


class GRUWithDones(RecurrentLayer):
    """``nn.GRU(input_size, hidden_size, num_layers)`` with episode restarts; the state is ``h`` (layers, N, H)."""

    def __init__(self, input_size: int, hidden_size: int, num_layers: int = 1) -> None:
        super().__init__(input_size, RnnConfig(name="gru", units=hidden_size, layers=num_layers))
