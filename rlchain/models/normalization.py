"""Running mean / std normalizers for observations and values, saved in checkpoints."""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import torch
import torch.nn as nn

from rlchain.envs.obs_dict import ObsDict, torch_dtype
from rlchain.parallel import communicator
from rlchain.parallel.communicator import merge_moments

CHUNK_ELEMENTS = 1 << 22  # rows per chunk of batch_moments: about this many values (16 MiB of float32)


def batch_moments(x: torch.Tensor, transform: Callable[[torch.Tensor], torch.Tensor] | None = None,
                  chunk_elements: int = CHUNK_ELEMENTS) -> tuple[torch.Tensor, torch.Tensor, int]:
    """Per-feature mean and population variance (float64) of the N rows of x (N, *shape), and N.

    Rows go through ``transform`` (e.g. uint8 -> float in [0, 1]) a chunk at a time and each chunk's
    moments are taken in float32, then merged exactly in float64: a rollout of Atari frames
    (8192 x 4 x 84 x 84) never exists as one float64 copy, and it is faster than making that copy.
    float64 input keeps float64.
    """
    n = x.shape[0]
    rows = max(1, chunk_elements // max(1, x[0].numel()))
    means, variances, counts = [], [], []
    for start in range(0, n, rows):
        chunk = x[start:start + rows]
        chunk = transform(chunk) if transform is not None else chunk
        if chunk.dtype != torch.float64:
            chunk = chunk.float()
        var, mean = torch.var_mean(chunk, dim=0, unbiased=False)
        means.append(mean.double())
        variances.append(var.double())
        counts.append(chunk.shape[0])
    if len(means) == 1:
        return means[0], variances[0], n
    mean, var, _ = merge_moments(torch.stack(means), torch.stack(variances),
                                 torch.tensor(counts, dtype=torch.float64, device=x.device))
    return mean, var, n


def _tracing() -> bool:
    """Whether a trace or compile is recording the calls (a cached value would be baked into it)."""
    compiling = getattr(getattr(torch, "compiler", None), "is_compiling", None)
    return torch.jit.is_tracing() or (compiling is not None and compiling())


class RunningMeanStd(nn.Module):
    """Tracks mean and variance over batches (Chan et al. parallel update), in float64; the buffers carry
    rl_games' names (``running_mean``, ``running_var``, ``count``), so its checkpoints load as they are.

    ``normalize(x)`` -> (x - mean) / sqrt(var + eps), clipped to +-clip when clip > 0;
    ``denormalize(y)`` is its inverse (no clip).
    """

    def __init__(self, shape: tuple[int, ...], epsilon: float = 1e-5, clip: float = 5.0) -> None:
        super().__init__()
        self.epsilon = epsilon
        self.clip = clip
        self.register_buffer("running_mean", torch.zeros(shape, dtype=torch.float64))
        self.register_buffer("running_var", torch.ones(shape, dtype=torch.float64))
        self.register_buffer("count", torch.ones((), dtype=torch.float64) * epsilon)
        # the ranks whose batches it folds in: the communicator in force when it is built (torchrun)
        self.comm = communicator.current()

    @torch.no_grad()
    def update(self, x: torch.Tensor, transform: Callable[[torch.Tensor], torch.Tensor] | None = None) -> None:
        """Fold a batch (N, *shape) into the running statistics (``transform`` maps raw rows to
        the normalized space first, chunk by chunk; see :func:`batch_moments`)."""
        if transform is None:
            x = x.reshape(-1, *self.running_mean.shape)
        batch_mean, batch_var, n = batch_moments(x, transform)
        if self.comm.active:  # multi_gpu: every rank folds the moments of all ranks' batches
            batch_mean, batch_var, n = self.comm.combine_moments(batch_mean, batch_var, n)
        delta = batch_mean - self.running_mean
        total = self.count + n
        self.running_mean += delta * n / total
        m2 = self.running_var * self.count + batch_var * n + delta.square() * self.count * n / total
        self.running_var.copy_(m2 / total)
        self.count.copy_(total)

    def normalize(self, x: torch.Tensor, scale: float = 1.0) -> torch.Tensor:
        """(x * scale - mean) / sqrt(var + eps), clipped; ``scale`` folds an input scaling (uint8
        frames / 255) into the same pass, which is one multiply-add over x instead of four passes."""
        shift, factor = self._affine(x, scale)
        y = torch.addcmul(shift, x, factor)
        return y.clamp_(-self.clip, self.clip) if self.clip > 0 else y

    def _affine(self, x: torch.Tensor, scale: float) -> tuple[torch.Tensor, torch.Tensor]:
        """(-mean / sqrt(var + eps), scale / sqrt(var + eps)) in x's dtype.

        On a CPU the pair is kept until the statistics change (the buffers' version counters move with every
        in-place write: an update, a checkpoint load) and reused: a PPO update normalizes hundreds of
        minibatches under the same statistics, and these six small ops cost about as much as the multiply-add.
        Elsewhere (CUDA, where a captured graph must read the live buffers; tracing; compiling) it is
        computed each call."""
        mean, var = self.running_mean, self.running_var
        key = None
        if x.device.type == "cpu" and not mean.is_inference() and not _tracing():
            key = (mean, mean._version, var, var._version, x.dtype, scale, torch.is_inference_mode_enabled())
            cached = getattr(self, "_affine_cache", None)
            if cached is not None and len(cached[0]) == len(key) \
                    and all(a is b or (type(a) is not torch.Tensor and a == b) for a, b in zip(cached[0], key)):
                return cached[1]
        inv = torch.rsqrt(var + self.epsilon)
        pair = (-mean * inv).to(x.dtype), (inv * scale).to(x.dtype)
        if key is not None:
            self._affine_cache = (key, pair)
        return pair

    def denormalize(self, y: torch.Tensor) -> torch.Tensor:
        return y * torch.sqrt(self.running_var.to(y.dtype) + self.epsilon) + self.running_mean.to(y.dtype)


class EmpiricalNormalization(RunningMeanStd):
    """rsl_rl's empirical normalization (``obs_normalizer: rsl_rl``): the same running mean and population
    variance over every row folded in (the statistics start empty: the first batch replaces the initial 0 / 1),
    applied as (x - mean) / (std + eps) with eps 1e-2 and no clip."""

    def __init__(self, shape: tuple[int, ...], epsilon: float = 1e-2) -> None:
        super().__init__(shape, epsilon=epsilon, clip=0.0)
        self.count.zero_()

    def normalize(self, x: torch.Tensor, scale: float = 1.0) -> torch.Tensor:
        """(x * scale - mean) / (sqrt(var) + eps)."""
        inv = 1.0 / (self.running_var.sqrt() + self.epsilon)
        return torch.addcmul((-self.running_mean * inv).to(x.dtype), x, (inv * scale).to(x.dtype))

    def denormalize(self, y: torch.Tensor) -> torch.Tensor:
        return y * (self.running_var.sqrt().to(y.dtype) + self.epsilon) + self.running_mean.to(y.dtype)


OBS_NORMALIZERS = ("rl_games", "rsl_rl")
"""``config.obs_normalizer``: rl_games = (x - mean) / sqrt(var + 1e-5) clipped to +-5 (rl_games' RunningMeanStd);
rsl_rl = (x - mean) / (std + 1e-2), no clip (rsl_rl's EmpiricalNormalization)."""


def obs_normalizer(shape: tuple[int, ...] | gym.spaces.Dict, kind: str = "rl_games",
                   exclude: tuple[str, ...] = ()) -> RunningMeanStd | DictNormalizer:
    """The observation normalizer ``kind`` (one of :data:`OBS_NORMALIZERS`) for observations of ``shape``;
    for a Dict space kept per key a :class:`DictNormalizer` (``exclude``: keys left as they are)."""
    if kind not in OBS_NORMALIZERS:
        raise ValueError(f"obs_normalizer must be one of {', '.join(OBS_NORMALIZERS)}, got {kind!r}")
    if isinstance(shape, gym.spaces.Dict):
        return DictNormalizer(shape, kind, exclude)
    return EmpiricalNormalization(shape) if kind == "rsl_rl" else RunningMeanStd(shape)


def dict_as_float(obs: ObsDict) -> ObsDict:
    """Every key as float32: uint8 images scaled to [0, 1], other keys cast (no copy when float32); int64 keys
    (Discrete / MultiDiscrete values, an embedding's indices) are left as they are."""
    return ObsDict({k: v if v.dtype == torch.int64 else v.float() / 255.0 if v.dtype == torch.uint8 else v.float()
                    for k, v in obs.items()}, obs.batch_dims)


class DictNormalizer(nn.Module):
    """Input normalization of Dict observations, key by key: a uint8 image is scaled to [0, 1] (a running
    mean/std per pixel would spend a pass over every frame to learn what /255 already gives), every other
    key gets its own running mean/std of ``kind``, keys in ``exclude`` are only cast to float, and a Discrete /
    MultiDiscrete key keeps its integer values (an embedding's indices have no mean to take)."""

    def __init__(self, space: gym.spaces.Dict, kind: str = "rl_games", exclude: tuple[str, ...] = ()) -> None:
        super().__init__()
        unknown = [k for k in exclude if k not in space.spaces]
        if unknown:
            raise ValueError(f"params.config.obs_normalizer_exclude: {unknown} are not keys of the observations "
                             f"({', '.join(space.spaces)})")
        # one normalizer per key under rl_games' name (its RunningMeanStdObs)
        self.running_mean_std = nn.ModuleDict({key: obs_normalizer(tuple(sub.shape), kind)
                                               for key, sub in space.spaces.items()
                                               if key not in exclude and torch_dtype(sub) == torch.float32})

    def normalize(self, obs: ObsDict, scale: float = 1.0) -> ObsDict:
        """Float observations, each normalized key by its own statistics (``scale`` unused: images are /255)."""
        out = dict_as_float(obs)
        for key, norm in self.running_mean_std.items():
            out[key] = norm.normalize(out[key])
        return out

    @torch.no_grad()
    def update(self, obs: ObsDict, transform: Callable | None = None) -> None:
        """Fold a batch (rows, ...) of every normalized key into its statistics (``transform`` unused)."""
        for key, norm in self.running_mean_std.items():
            norm.update(obs[key].float())
