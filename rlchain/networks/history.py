"""The ``history:`` block: a causal transformer over the last ``length`` steps' encoded observations.

It takes the recurrent layer's place in the trunk (after the MLP) and its interface: the window of past
steps is the state the rollout carries, stores with every step and zeroes where an episode ends, exactly as
an LSTM's (h, c), so training uses the RNN path's sequence minibatches and playing steps it one step at a
time. The state is two tensors: ``window`` (length - 1, B, dim), the projected features of the previous
steps (oldest first), and ``valid`` (length - 1, B, 1), 1 where a slot holds a step of the current episode.

Each step's output is the transformer's output at its own token, over the window ending at it (the
previous ``length - 1`` steps and itself), with a causal mask and the invalid slots masked out; a step
whose observation starts an episode (``resets``) sees no earlier step. Training and playing compute the
same function of the same window, whether the window comes from the carried state or from the earlier
steps of a training sequence. Exported to ONNX, the window and its validity are graph inputs and outputs.
"""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.config.network import HistoryConfig

States = tuple[torch.Tensor, ...]


class CausalBlock(nn.Module):
    """Pre-norm transformer block: masked multi-head self-attention, then a 2-layer MLP, both residual.
    Plain tensor ops (no fused kernels), so the ONNX graph is exactly the PyTorch computation."""

    def __init__(self, dim: int, heads: int) -> None:
        super().__init__()
        self.heads = heads
        self.norm1, self.norm2 = nn.LayerNorm(dim), nn.LayerNorm(dim)
        self.qkv = nn.Linear(dim, 3 * dim)
        self.out = nn.Linear(dim, dim)
        self.mlp = nn.Sequential(nn.Linear(dim, 2 * dim), nn.GELU(), nn.Linear(2 * dim, dim))

    def forward(self, x: torch.Tensor, blocked: torch.Tensor) -> torch.Tensor:
        """x (N, K, dim); ``blocked`` (N, 1, K, K) bool, True where query row may not see key column."""
        n, k, dim = x.shape
        q, key, v = self.qkv(self.norm1(x)).reshape(n, k, 3, self.heads, dim // self.heads).permute(2, 0, 3, 1, 4)
        scores = q @ key.transpose(-1, -2) * (dim // self.heads) ** -0.5  # (N, heads, K, K)
        weights = torch.softmax(scores.masked_fill(blocked, float("-inf")), -1)
        x = x + self.out((weights @ v).transpose(1, 2).reshape(n, k, dim))
        return x + self.mlp(self.norm2(x))


class HistoryLayer(nn.Module):
    """(B*L, in_size) features in sequence-major blocks -> (B*L, dim), new (window, valid) states."""

    def __init__(self, in_size: int, cfg: HistoryConfig) -> None:
        super().__init__()
        if cfg.dim % cfg.heads:
            raise ValueError(f"params.network.history.dim: {cfg.dim} must divide by heads ({cfg.heads})")
        self.length, self.dim = cfg.length, cfg.dim
        self.num_states = 2
        self.proj = nn.Linear(in_size, cfg.dim)
        self.position = nn.Parameter(torch.zeros(cfg.length, cfg.dim))  # by slot: oldest .. current
        nn.init.normal_(self.position, std=0.02)
        self.blocks = nn.ModuleList(CausalBlock(cfg.dim, cfg.heads) for _ in range(cfg.layers))
        self.norm = nn.LayerNorm(cfg.dim)
        self.out_size = cfg.dim
        causal = torch.ones(cfg.length, cfg.length, dtype=torch.bool).triu(1)
        self.register_buffer("causal", causal, persistent=False)

    def initial_state(self, batch: int, device: torch.device) -> States:
        """An empty window for ``batch`` sequences: zero features, no valid slot."""
        past = self.length - 1
        return (torch.zeros(past, batch, self.dim, device=device), torch.zeros(past, batch, 1, device=device))

    def forward(self, x: torch.Tensor, states: States, resets: torch.Tensor | None,
                seq_length: int, bptt_length: int | None = None) -> tuple[torch.Tensor, States]:
        """``bptt_length`` has no meaning here (the window is a plain input): accepted and unused."""
        rows = x.shape[0]
        batch, steps, past = rows // seq_length, seq_length, self.length - 1
        feats = self.proj(x).reshape(batch, steps, self.dim)
        window, valid = states[0].permute(1, 0, 2), states[1].permute(1, 0, 2)[..., 0] > 0.5  # (B, K-1, D), (B, K-1)
        seq = torch.cat((window, feats), 1)  # (B, K-1+L, D): the carried window, then this sequence's steps
        ok = torch.cat((valid, torch.ones(batch, steps, dtype=torch.bool, device=x.device)), 1)
        if resets is not None:  # a step that starts an episode sees no earlier one: episode ids along the sequence
            starts = resets.reshape(batch, steps).long().cumsum(1)
            episode = torch.cat((torch.zeros(batch, past, dtype=torch.long, device=x.device), starts), 1)
        else:
            episode = torch.zeros(batch, past + steps, dtype=torch.long, device=x.device)
        if steps == 1:  # one step (the rollout, play, export): the whole sequence is the window
            tokens, ok_w, ep_w = seq.unsqueeze(1), ok.unsqueeze(1), episode.unsqueeze(1)
        else:  # each step's window of `length` slots ending at it: (B, L, K, D)
            tokens = seq.unfold(1, self.length, 1).permute(0, 1, 3, 2)
            ok_w, ep_w = ok.unfold(1, self.length, 1), episode.unfold(1, self.length, 1)
        seen = ok_w & (ep_w == ep_w[..., -1:])  # (B, L, K): slots of the query step's episode
        out = self._attend(tokens.reshape(-1, self.length, self.dim), seen.reshape(-1, self.length))
        keep = ok & (episode == episode[:, -1:])  # the next step's window: this episode's slots only
        new_window = seq[:, -past:].permute(1, 0, 2)
        new_valid = keep[:, -past:].to(x.dtype).permute(1, 0).unsqueeze(-1)
        return out.reshape(rows, self.dim), (new_window, new_valid)

    def _attend(self, tokens: torch.Tensor, seen: torch.Tensor) -> torch.Tensor:
        """tokens (N, K, D), ``seen`` (N, K) bool (the last slot, the current step, always) -> (N, D) at the
        last slot. A slot may always see itself, so no row of the attention is empty."""
        x = tokens + self.position
        eye = torch.eye(self.length, dtype=torch.bool, device=x.device)
        blocked = (self.causal | ~seen.unsqueeze(1)) & ~eye  # (N, K, K)
        blocked = blocked.unsqueeze(1)
        for block in self.blocks:
            x = block(x, blocked)
        return self.norm(x[:, -1])
