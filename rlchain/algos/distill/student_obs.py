"""The student's observations in ``algo: distill``: corrupted and delayed while training, stored per step.

Observations are a flat tensor (N, F) or Dict observations kept per key (an
:class:`~rlchain.envs.obs_dict.ObsDict`: a camera image beside proprioception). Every helper here takes
either, so the rollout keeps each key in its own dtype (uint8 images stay uint8 until the network).
"""

from __future__ import annotations

from typing import Any

import torch

from rlchain.envs.obs_dict import ObsDict

Obs = Any  # torch.Tensor | ObsDict


def corrupt(obs: Obs, noise_std: float, dropout: float) -> Obs:
    """``obs`` with Gaussian noise (``noise_std``) added and each element zeroed with probability ``dropout``
    (a new tensor; ``obs`` itself when both are 0). Of an ObsDict only the float keys are corrupted: an
    image's bytes and a Discrete key's values pass as they are."""
    if noise_std <= 0.0 and dropout <= 0.0:
        return obs
    if isinstance(obs, ObsDict):
        return ObsDict({k: corrupt(v, noise_std, dropout) if v.is_floating_point() else v for k, v in obs.items()},
                       obs.batch_dims)
    out = obs.float()
    if noise_std > 0.0:
        out = out + noise_std * torch.randn_like(out)
    if dropout > 0.0:
        out = out * (torch.rand_like(out) >= dropout).to(out.dtype)
    return out


class DelayLine:
    """The student's view ``delay`` steps late (a slow sensor): :meth:`push` takes this step's observations
    (N, ...) and returns the ones of ``delay`` steps ago; an env whose episode starts (``starts`` (N,) bool)
    has its line filled with its first observation. An ObsDict goes through one line per key."""

    def __init__(self, delay: int) -> None:
        self.delay = delay
        self.line: torch.Tensor | dict[str, DelayLine] | None = None  # (delay + 1, N, ...), oldest first

    def push(self, obs: Obs, starts: torch.Tensor) -> Obs:
        """This step's observations in, those of ``delay`` steps ago out (``obs`` itself when delay is 0)."""
        if self.delay == 0:
            return obs
        if isinstance(obs, ObsDict):
            if self.line is None:
                self.line = {k: DelayLine(self.delay) for k in obs}
            return ObsDict({k: self.line[k].push(v, starts) for k, v in obs.items()}, obs.batch_dims)
        if self.line is None:
            self.line = obs.unsqueeze(0).repeat(self.delay + 1, *([1] * obs.dim())).clone()
        self.line = torch.cat([self.line[1:], obs.unsqueeze(0)], 0)
        if bool(starts.any()):
            self.line[:, starts] = obs[starts].unsqueeze(0)
        return self.line[0]


def stack_steps(steps: list[Obs]) -> Obs:
    """T steps of (N, ...) observations -> (T, N, ...), an ObsDict key by key (each keeps its dtype)."""
    if isinstance(steps[0], ObsDict):
        return ObsDict({k: torch.stack([s[k] for s in steps]) for k in steps[0]}, steps[0].batch_dims + 1)
    return torch.stack(steps)


def cat_envs(parts: list[Obs]) -> Obs:
    """Rollouts (T, N_i, ...) side by side along the env axis -> (T, sum N_i, ...), an ObsDict key by key."""
    if isinstance(parts[0], ObsDict):
        return ObsDict({k: torch.cat([p[k] for p in parts], 1) for k in parts[0]}, parts[0].batch_dims)
    return torch.cat(parts, 1)


def merge_steps(x: Obs) -> Obs:
    """(T, N, ...) -> (T * N, ...): the two leading batch dims as one (an ObsDict's keys keep their shapes)."""
    return x.reshape(-1) if isinstance(x, ObsDict) else x.flatten(0, 1)


def env_rows(x: Obs, envs: torch.Tensor) -> Obs:
    """(T, N, ...) -> (len(envs) * T, ...): the rollouts of ``envs``, env by env (sequence-major for an RNN)."""
    return merge_steps(x[:, envs].transpose(0, 1))
