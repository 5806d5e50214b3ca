"""The learner's view of a batch of fragments: stacked side by side, and a policy's pass over them.

Fragments of the same length T from several runners become one (T + 1, N) batch, envs numbered across the
fragments in their order. A feed-forward policy values the (T + 1) * N observations as flat rows; a recurrent
one runs each env's T + 1 steps as one sequence from the RNN state its runner had at the fragment's start,
zeroed where an episode starts (``resets``), so the learner's values and log-probs follow the same memory the
runner's policy had.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from rlchain.algos.appo.fragments import Fragment


@dataclass
class FragmentBatch:
    """Fragments stacked along the env dimension (N envs in all), on the learner's device.

    ``obs`` (T + 1, N, ...); ``actions`` (T, N, ...); ``log_probs`` (T, N) the behaviour policy's;
    ``rewards`` (T, N[, V]); ``terminated`` / ``truncated`` (T, N) bool. Recurrent policies: ``states`` the
    RNN states entering every step, each (T + 1, layers, N, units); ``resets`` (T + 1, N) bool, the steps whose
    observation starts an episode. Feed-forward: ``()`` and None.
    """

    obs: torch.Tensor
    actions: torch.Tensor
    log_probs: torch.Tensor
    rewards: torch.Tensor
    terminated: torch.Tensor
    truncated: torch.Tensor
    states: tuple[torch.Tensor, ...] = ()
    resets: torch.Tensor | None = None

    @classmethod
    def stack(cls, frags: list[Fragment], device: torch.device) -> FragmentBatch:
        def cat(name: str) -> torch.Tensor:
            return torch.cat([getattr(f, name) for f in frags], dim=1).to(device)

        recurrent = bool(frags[0].states)
        states = tuple(torch.cat([f.states[i] for f in frags], dim=2).to(device)
                       for i in range(len(frags[0].states)))
        return cls(obs=cat("obs"), actions=cat("actions"), log_probs=cat("log_probs"), rewards=cat("rewards").float(),
                   terminated=cat("terminated").bool(), truncated=cat("truncated").bool(), states=states,
                   resets=cat("resets").bool() if recurrent else None)


def policy_pass(model: torch.nn.Module, batch: FragmentBatch) -> tuple[torch.Tensor, torch.Tensor]:
    """``model``'s distribution params (T + 1, N, P) and raw-scale values (T + 1, N, V) of every observation of
    the batch (the caller holds no_grad and eval mode)."""
    obs = batch.obs
    steps, n = obs.shape[:2]
    if not model.is_rnn:
        params, raw, _ = model.evaluate(obs.reshape(steps * n, *obs.shape[2:]))
        return params.reshape(steps, n, -1), model.denorm_value(raw).reshape(steps, n, -1)
    # each env's steps as one sequence: rows sequence-major (env 0's T + 1 steps, then env 1's, ...)
    seq = obs.transpose(0, 1).reshape(n * steps, *obs.shape[2:])
    resets = batch.resets.transpose(0, 1).reshape(-1)
    params, raw, _ = model.evaluate(seq, tuple(s[0] for s in batch.states), resets, seq_length=steps)

    def time_major(x: torch.Tensor) -> torch.Tensor:
        return x.reshape(n, steps, -1).transpose(0, 1)

    return time_major(params), time_major(model.denorm_value(raw))


def final_values(model: torch.nn.Module, frags: list[Fragment], device: torch.device
                 ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor] | None:
    """(steps, envs, V(final obs)) of the batch's episode ends, envs numbered across the fragments; a recurrent
    policy values each final observation from the RNN state its runner had after the episode's last step."""
    steps, final_obs, final_states, offset = [], [], [], 0
    for f in frags:
        if f.final_steps.numel():
            steps.append(f.final_steps + torch.tensor([0, offset]))
            final_obs.append(f.final_obs)
            final_states.append(f.final_states)
        offset += f.log_probs.shape[1]
    if not steps:
        return None
    idx = torch.cat(steps).to(device)
    states = tuple(torch.cat([s[i] for s in final_states], dim=1).to(device) for i in range(len(final_states[0])))
    values = model.value(torch.cat(final_obs).to(device), states or None)
    return idx[:, 0], idx[:, 1], values
