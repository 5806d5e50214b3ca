"""rl_games' ``common.layers.recurrent``: LSTM / GRU over (T, N, F) sequences that restart at episode ends.

The layer is held as ``.rnn`` inside a wrapper, so a network's state dict reads ``<name>.rnn.weight_ih_l0``
as rl_games' does (its checkpoints load as written).
"""

from __future__ import annotations

import torch
import torch.nn as nn

Hidden = torch.Tensor | tuple[torch.Tensor, ...]


def _scale(hidden: Hidden, factor: torch.Tensor) -> Hidden:
    """Every state tensor times ``factor`` (1, N, 1): 0 clears the envs whose episode starts here."""
    return hidden * factor if isinstance(hidden, torch.Tensor) else tuple(h * factor for h in hidden)


def _detach(hidden: Hidden) -> Hidden:
    return hidden.detach() if isinstance(hidden, torch.Tensor) else tuple(h.detach() for h in hidden)


class RnnWithDones(nn.Module):
    """``forward(input (T, N, F), states, done_masks (T, N, 1) or None, bptt_len)`` -> (output (T, N, H), states).

    ``done_masks[t]`` marks envs whose step t starts a new episode: their state entering t is zeroed. The
    sequence runs in one call per stretch without such a start; ``bptt_len`` > 0 also cuts the gradient
    through the state every ``bptt_len`` steps.
    """

    def __init__(self, rnn: nn.Module) -> None:
        super().__init__()
        self.rnn = rnn

    def forward(self, input: torch.Tensor, states: Hidden, done_masks: torch.Tensor | None = None,
                bptt_len: int = 0) -> tuple[torch.Tensor, Hidden]:
        steps = input.shape[0]
        if states is None or (isinstance(states, tuple) and not states):
            states = None  # torch starts from zeros
        cuts = {0, steps}
        if done_masks is not None:
            starts = done_masks.reshape(steps, -1).bool().any(-1)
            cuts.update(int(t) for t in torch.nonzero(starts[1:]).flatten() + 1)
        if bptt_len and bptt_len > 0:
            cuts.update(range(bptt_len, steps, bptt_len))
        bounds = sorted(cuts)
        if len(bounds) == 2 and done_masks is None:
            return self.rnn(input, states)
        outs = []
        for start, end in zip(bounds[:-1], bounds[1:]):
            if states is not None:
                if bptt_len and bptt_len > 0 and start and start % bptt_len == 0:
                    states = _detach(states)
                if done_masks is not None:
                    keep = 1.0 - done_masks[start].reshape(1, -1, 1).to(input.dtype)
                    states = _scale(states, keep)
            out, states = self.rnn(input[start:end], states)
            outs.append(out)
        return torch.cat(outs, 0), states


class LSTMWithDones(RnnWithDones):
    """``nn.LSTM(*args, **kwargs)`` with episode restarts; states are ``(h, c)``, each (layers, N, H)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(nn.LSTM(*args, **kwargs))


class GRUWithDones(RnnWithDones):
    """``nn.GRU(*args, **kwargs)`` with episode restarts; the state is ``h`` (layers, N, H)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(nn.GRU(*args, **kwargs))
