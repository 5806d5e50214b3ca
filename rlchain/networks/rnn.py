"""The recurrent layer of the ``rnn:`` block (LSTM or GRU), rl_games' ``LSTMWithDones`` / ``GRUWithDones``."""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.config.network import RnnConfig

States = tuple[torch.Tensor, ...]  # (h,) for GRU, (h, c) for LSTM; each (layers, B, units)
Hidden = torch.Tensor | tuple[torch.Tensor, ...]  # what nn.GRU (h) or nn.LSTM ((h, c)) takes and returns


class RecurrentLayer(nn.Module):
    """rl_games' recurrent layer: ``forward(input (T, N, F), states, done_masks (T, N[, 1]) or None, bptt_len)``
    -> (output (T, N, units), states), the states as ``nn.LSTM`` / ``nn.GRU`` take them ((h, c) / h; a 1-tuple
    (h,) is read as h; None starts from zeros).

    ``done_masks[t]`` marks envs whose step t starts a new episode: the state entering that step is zeroed, so a
    sequence that crosses an episode boundary never leaks memory across it. ``bptt_len`` > 0 and < T truncates
    backpropagation: the state is detached every ``bptt_len`` steps (its value still flows forward). The module is
    ``rnn`` (state dict ``<name>.rnn.weight_ih_l0``, rl_games' keys); the ``rnn.layer_norm`` LayerNorm on the
    output is the network's own module (rl_games' ``layer_norm``), not this layer's. Flat rows in sequence-major
    blocks go through :func:`flat_sequences`.
    """

    def __init__(self, in_size: int, cfg: RnnConfig) -> None:
        super().__init__()
        cls = nn.LSTM if cfg.name == "lstm" else nn.GRU
        self.rnn = cls(in_size, cfg.units, cfg.layers)
        self.num_states = 2 if cfg.name == "lstm" else 1
        self.layers, self.units = cfg.layers, cfg.units
        self.out_size = cfg.units

    def initial_state(self, batch: int, device: torch.device | None = None) -> States:
        """Zero states for ``batch`` sequences."""
        return tuple(torch.zeros(self.layers, batch, self.units, device=device) for _ in range(self.num_states))

    def forward(self, input: torch.Tensor, states: Hidden | None = None, done_masks: torch.Tensor | None = None,
                bptt_len: int | None = 0) -> tuple[torch.Tensor, Hidden]:
        steps, batch = input.shape[0], input.shape[1]
        if states is None or (isinstance(states, (tuple, list)) and not states):
            states = self.initial_state(batch, input.device)
        hidden = tuple(states) if self.num_states == 2 else (states[0] if isinstance(states, (tuple, list))
                                                              else states)
        truncate = bool(bptt_len) and 0 < bptt_len < steps
        if not truncate and (done_masks is None or not bool(done_masks.any())):
            return self.rnn(input, hidden)
        keep = None
        if done_masks is not None:
            keep = (~done_masks.reshape(steps, batch).bool()).to(input.dtype).unsqueeze(-1)  # (T, N, 1)
        outs = []
        for t in range(steps):
            if truncate and t and t % bptt_len == 0:
                hidden = _detach(hidden)
            if keep is not None:
                hidden = _mask(hidden, keep[t])
            step, hidden = self.rnn(input[t:t + 1], hidden)
            outs.append(step)
        return torch.cat(outs, 0), hidden


def flat_sequences(rnn: nn.Module, x: torch.Tensor, states: States, resets: torch.Tensor | None, seq_length: int,
                   bptt_length: int | None = None) -> tuple[torch.Tensor, States]:
    """(B*L, in_size) features in sequence-major blocks (rows ``i*L .. i*L+L-1`` are the L steps of sequence i)
    through ``rnn`` (any module with rl_games' recurrent call) -> (B*L, units) and the new states as a tuple.
    ``resets`` (B*L,) marks rows whose observation starts a new episode."""
    rows, features = x.shape
    batch = rows // seq_length
    seq = x.reshape(batch, seq_length, features).transpose(0, 1)  # (L, B, F)
    dones = resets.reshape(batch, seq_length).transpose(0, 1) if resets is not None else None
    out, hidden = rnn(seq, tuple(states) if states else None, dones, bptt_length)
    out = out.transpose(0, 1).reshape(rows, out.shape[-1])
    return out, (tuple(hidden) if isinstance(hidden, (tuple, list)) else (hidden,))


def _mask(hidden: Hidden, keep: torch.Tensor) -> Hidden:
    """Zero the state of sequences whose next step starts an episode; ``keep`` is (B, 1)."""
    if isinstance(hidden, tuple):
        return tuple(h * keep for h in hidden)
    return hidden * keep


def _detach(hidden: Hidden) -> Hidden:
    """Cut the gradient path through the state (truncated BPTT)."""
    if isinstance(hidden, tuple):
        return tuple(h.detach() for h in hidden)
    return hidden.detach()


def zero_finished(states: States, dones: torch.Tensor) -> States:
    """RNN states (each (layers, B, units)) with the rows of finished episodes (``dones`` (B,)) zeroed."""
    if not states:
        return states
    return _mask(tuple(states), (~dones.bool()).to(states[0].dtype).view(-1, 1))
