"""The recurrent layer of the ``rnn:`` block (LSTM or GRU), rl_games' ``LSTMWithDones`` / ``GRUWithDones``."""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.config.network import RnnConfig

CELL_MAX_BATCH = 64
"""Most sequences whose one-step LSTM goes through ``torch.lstm_cell`` on a CPU (measured with 256 units, one thread:
3-7x faster than nn.LSTM up to 16, 2x at 64, 10% slower from 256 on)."""

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
            return self._run(input, hidden)
        keep = None
        if done_masks is not None:
            keep = (~done_masks.reshape(steps, batch).bool()).to(input.dtype).unsqueeze(-1)  # (T, N, 1)
        # the state is cut (a reset) or detached (bptt) only at some steps: the layer runs in one call from each
        # such step to the next (the outputs of one call per step, in a few calls)
        cuts = set(range(bptt_len, steps, bptt_len)) if truncate else set()
        if keep is not None:
            cuts.update((keep[1:, :, 0] == 0).any(1).nonzero().flatten().add(1).tolist())
        starts = [0, *sorted(cuts)]
        outs = []
        for start, end in zip(starts, [*starts[1:], steps]):
            if truncate and start and start % bptt_len == 0:
                hidden = _detach(hidden)
            if keep is not None:
                hidden = _mask(hidden, keep[start])
            out, hidden = self._run(input[start:end], hidden)
            outs.append(out)
        return torch.cat(outs, 0) if len(outs) > 1 else outs[0], hidden

    def _run(self, input: torch.Tensor, hidden: Hidden) -> tuple[torch.Tensor, Hidden]:
        """The recurrent module over ``input`` (T, N, F). One step of an LSTM on a CPU for at most
        :data:`CELL_MAX_BATCH` sequences (an env step of the rollout) goes through ``torch.lstm_cell``: nn.LSTM
        takes oneDNN's kernel there, whose set-up per call costs 3-7x the cell's arithmetic at these sizes."""
        if input.shape[0] != 1 or self.num_states != 2 or input.device.type != "cpu" \
                or input.shape[1] > CELL_MAX_BATCH:
            return self.rnn(input, hidden)
        h, c = hidden
        x, hs, cs = input[0], [], []
        for layer in range(self.layers):
            x, cell = torch.lstm_cell(x, (h[layer], c[layer]), *self.rnn.all_weights[layer])
            hs.append(x)
            cs.append(cell)
        return x.unsqueeze(0), (torch.stack(hs), torch.stack(cs))


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
