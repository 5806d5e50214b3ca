"""The recurrent layer of the ``rnn:`` block (LSTM or GRU) over flat (B*L) sequence batches."""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.config.network import RnnConfig

States = tuple[torch.Tensor, ...]  # (h,) for GRU, (h, c) for LSTM; each (layers, B, units)


class RecurrentLayer(nn.Module):
    """(B*L, in_size) features in sequence-major blocks -> (B*L, units), new states.

    Rows are ordered sequence by sequence: rows ``i*L .. i*L+L-1`` are the L steps of sequence i.
    ``resets`` (B*L,) marks rows whose observation starts a new episode: the state entering that
    step is zeroed, so a sequence that crosses an episode boundary never leaks memory across it.
    The recurrent module is ``rnn`` (rl_games' ``LSTMWithDones.rnn``); the ``rnn.layer_norm`` LayerNorm on the
    output is the network's own module (rl_games' ``layer_norm``), not this layer's.
    """

    def __init__(self, in_size: int, cfg: RnnConfig) -> None:
        super().__init__()
        cls = nn.LSTM if cfg.name == "lstm" else nn.GRU
        self.rnn = cls(in_size, cfg.units, cfg.layers)
        self.num_states = 2 if cfg.name == "lstm" else 1
        self.layers, self.units = cfg.layers, cfg.units
        self.out_size = cfg.units

    def initial_state(self, batch: int, device: torch.device) -> States:
        """Zero states for ``batch`` sequences."""
        return tuple(torch.zeros(self.layers, batch, self.units, device=device) for _ in range(self.num_states))

    def forward(self, x: torch.Tensor, states: States, resets: torch.Tensor | None,
                seq_length: int, bptt_length: int | None = None) -> tuple[torch.Tensor, States]:
        """``bptt_length`` < seq_length truncates backpropagation: the state is detached every
        ``bptt_length`` steps (its value still flows forward)."""
        rows, features = x.shape
        batch = rows // seq_length
        seq = x.reshape(batch, seq_length, features).transpose(0, 1)  # (L, B, F)
        hidden = states if self.num_states == 2 else states[0]
        truncate = bptt_length is not None and bptt_length < seq_length
        if not truncate and (resets is None or not bool(resets.any())):
            out, hidden = self.rnn(seq, hidden)
        else:
            keep = None
            if resets is not None:
                keep = (~resets.reshape(batch, seq_length).transpose(0, 1)).to(x.dtype).unsqueeze(-1)  # (L, B, 1)
            outs = []
            for t in range(seq_length):
                if truncate and t and t % bptt_length == 0:
                    hidden = _detach(hidden)
                if keep is not None:
                    hidden = _mask(hidden, keep[t])
                step, hidden = self.rnn(seq[t:t + 1], hidden)
                outs.append(step)
            out = torch.cat(outs, 0)
        out = out.transpose(0, 1).reshape(rows, self.units)
        return out, (tuple(hidden) if self.num_states == 2 else (hidden,))


def _mask(hidden: torch.Tensor | tuple, keep: torch.Tensor) -> torch.Tensor | tuple:
    """Zero the state of sequences whose next step starts an episode; ``keep`` is (B, 1)."""
    if isinstance(hidden, tuple):
        return tuple(h * keep for h in hidden)
    return hidden * keep


def _detach(hidden: torch.Tensor | tuple) -> torch.Tensor | tuple:
    """Cut the gradient path through the state (truncated BPTT)."""
    if isinstance(hidden, tuple):
        return tuple(h.detach() for h in hidden)
    return hidden.detach()


def zero_finished(states: States, dones: torch.Tensor) -> States:
    """RNN states (each (layers, B, units)) with the rows of finished episodes (``dones`` (B,)) zeroed."""
    if not states:
        return states
    return _mask(tuple(states), (~dones.bool()).to(states[0].dtype).view(-1, 1))
