"""Action distributions. Every action-space difference lives here, none in the algorithm.

A distribution works on a flat parameter tensor ``params`` (B, param_size) that the rollout
storage keeps for the KL term: logits for Categorical, the concatenated logits of every
dimension for MultiCategorical, ``cat(mu, sigma)`` for DiagGaussian.

Action masks (``config.use_action_masks``): ``mask(params, masks)`` takes a bool tensor
(B, mask_size), True where an action is allowed, and returns params whose invalid logits are
:data:`MASKED_LOGIT` (a large finite negative number, so entropy and KL stay finite and the
masked actions get probability 0). The model applies it right after ``params_from_network``;
the masked params are what the storage keeps, so the PPO ratio and KL use the same masks.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
import torch

MASKED_LOGIT = -1e8
"""Logit of a masked action (rl_games uses the same value); clamped to the dtype's range."""


class ActionMaskError(ValueError):
    """An action mask of the wrong shape, or a row (or a dimension of it) with no valid action."""


class Distribution:
    """Interface used by the PPO loss, the rollout and the Player.

    ``mask_size`` is the width of the action masks :meth:`mask` takes (0: masks not supported).
    """

    param_size: int
    action_shape: tuple[int, ...]
    action_dtype: torch.dtype
    mask_size: int = 0
    continuous: bool = False
    """True for real-valued actions (the adaptive lr's ``kl_reference: auto`` follows it)."""

    def params_from_network(self, out: tuple) -> tuple[torch.Tensor, torch.Tensor]:
        """Split a network's output tuple into (params, value)."""
        raise NotImplementedError

    def sample(self, params: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def mode(self, params: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def log_prob(self, params: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def entropy(self, params: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def kl(self, old: torch.Tensor, new: torch.Tensor) -> torch.Tensor:
        """KL(old || new) per sample."""
        raise NotImplementedError

    def log_prob_and_entropy(self, params: torch.Tensor, actions: torch.Tensor
                             ) -> tuple[torch.Tensor, torch.Tensor]:
        """Both at once (the PPO loss needs both; subclasses share the work)."""
        return self.log_prob(params, actions), self.entropy(params)

    def bounds_loss(self, params: torch.Tensor, kind: str) -> torch.Tensor:
        """Auxiliary loss keeping continuous means in range; zero for discrete actions."""
        return torch.zeros(params.shape[0], device=params.device)

    def mask(self, params: torch.Tensor, masks: torch.Tensor, check: bool = True) -> torch.Tensor:
        """params (B, param_size) restricted to the actions ``masks`` (B, mask_size) bool allows.

        ``check=False`` skips the "no valid action" check, a data-dependent branch that an exported
        (traced) graph cannot hold; the result is otherwise the same."""
        raise ActionMaskError(f"{type(self).__name__} does not support action masks "
                              "(params.config.use_action_masks needs discrete or multi-discrete actions)")

    def to_env(self, actions: torch.Tensor) -> torch.Tensor:
        """Map sampled actions to what the env accepts (clip/rescale for Box)."""
        return actions


def _masked_logit(dtype: torch.dtype) -> float:
    return max(MASKED_LOGIT, torch.finfo(dtype).min)


def _apply_mask(params: torch.Tensor, masks: torch.Tensor, mask_size: int
                ) -> tuple[torch.Tensor, torch.Tensor]:
    """(logits with ``~masks`` set to MASKED_LOGIT, masks as a bool tensor); checks the shape."""
    if isinstance(masks, torch.Tensor):  # .to, not as_tensor, which tracing (ONNX export) may record as a constant
        masks = masks.to(device=params.device, dtype=torch.bool)
    else:
        masks = torch.as_tensor(masks, dtype=torch.bool, device=params.device)
    if masks.shape != params.shape:
        raise ActionMaskError(f"action mask has shape {tuple(masks.shape)}, expected "
                              f"({params.shape[0]}, {mask_size}) (batch, mask_size) bool")
    return params.masked_fill(~masks, _masked_logit(params.dtype)), masks


def _no_valid_rows(valid: torch.Tensor) -> None:
    """Raise when ``valid`` (B,) or (B, K) has a False entry: a row/dimension with no valid action."""
    if not bool(valid.all()):
        bad = (~valid).nonzero()[0].tolist()
        where = f"row {bad[0]}" + (f", action dimension {bad[1]}" if len(bad) > 1 else "")
        raise ActionMaskError(f"action mask {where} allows no action: every sub-action needs at least "
                              "one True entry (check the env's get_action_mask())")


class Categorical(Distribution):
    """Discrete(n): params are logits (B, n); actions are int64 (B,); masks (B, n)."""

    def __init__(self, n: int, start: int = 0) -> None:
        self.param_size = n
        self.mask_size = n
        self.action_shape = ()
        self.action_dtype = torch.long
        self.start = int(start)

    def params_from_network(self, out: tuple) -> tuple[torch.Tensor, torch.Tensor]:
        return out[0], out[1]

    @staticmethod
    def _log_softmax(params: torch.Tensor) -> torch.Tensor:
        return _log_softmax_last(params)

    def sample(self, params: torch.Tensor) -> torch.Tensor:
        return _gumbel_argmax(params)

    def mode(self, params: torch.Tensor) -> torch.Tensor:
        return params.argmax(-1)

    def log_prob(self, params: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        return self._log_softmax(params).gather(-1, actions.long().unsqueeze(-1)).squeeze(-1)

    def entropy(self, params: torch.Tensor) -> torch.Tensor:
        logp = self._log_softmax(params)
        return -(logp.exp() * logp).sum(-1)

    def log_prob_and_entropy(self, params: torch.Tensor, actions: torch.Tensor
                             ) -> tuple[torch.Tensor, torch.Tensor]:
        logp = self._log_softmax(params)
        return logp.gather(-1, actions.long().unsqueeze(-1)).squeeze(-1), -(logp.exp() * logp).sum(-1)

    def kl(self, old: torch.Tensor, new: torch.Tensor) -> torch.Tensor:
        old_logp, new_logp = self._log_softmax(old), self._log_softmax(new)
        return (old_logp.exp() * (old_logp - new_logp)).sum(-1)

    def mask(self, params: torch.Tensor, masks: torch.Tensor, check: bool = True) -> torch.Tensor:
        """Invalid logits become MASKED_LOGIT; a row with no True entry raises ActionMaskError."""
        out, masks = _apply_mask(params, masks, self.mask_size)
        if check:
            _no_valid_rows(masks.any(-1))
        return out

    def to_env(self, actions: torch.Tensor) -> torch.Tensor:
        """Indices 0..n-1 shifted by the space's ``start`` (gymnasium Discrete(n, start))."""
        return actions + self.start if self.start else actions


SHORT_ROW = 8
"""Logit rows up to this long take the transposed log_softmax on CPU (:func:`_log_softmax_last`)."""


def _log_softmax_last(logits: torch.Tensor) -> torch.Tensor:
    """log_softmax over the last dim of (B, n) logits, computed over dim 0 of the transposed view.

    The same values bit for bit; on CPU, a reduction along a short contiguous last dim (n = 2 for
    CartPole) runs one row at a time, while along dim 0 it vectorizes over the batch: faster for up to
    ``SHORT_ROW`` actions, forward and backward (slower for long rows). Other shapes take the plain call.

    Only where no gradient is taken (the rollout's act step): the backward of the transposed form rounds
    differently from torch's (~1e-7), and over many epochs such rounding moves a seed's learning curve (a
    self-play run's win rate), so the update keeps torch's call and its gradients are torch's own."""
    if (logits.dim() == 2 and logits.shape[1] <= SHORT_ROW and logits.device.type == "cpu"
            and not (torch.is_grad_enabled() and logits.requires_grad)):
        return torch.log_softmax(logits.t(), 0).t()
    return torch.log_softmax(logits, -1)


def _gumbel_argmax(logits: torch.Tensor) -> torch.Tensor:
    """One categorical sample per row of the last dim (Gumbel-max: cheaper than multinomial on CPU).

    The Gumbel noise is bounded (u in [1e-20, 1)), so a MASKED_LOGIT entry is never chosen."""
    u = torch.rand_like(logits).clamp_(1e-20, 1.0)
    return (logits - u.log_().neg_().log_()).argmax(-1)  # log(-log u) in place: the same values, no temporaries


class MultiCategorical(Distribution):
    """Independent categoricals, one per action dimension: MultiDiscrete(nvec), Tuple(Discrete, ...),
    MultiBinary(n) (nvec = [2] * n).

    Shapes: params are the concatenated logits (B, sum(nvec)); actions int64 (B, K) with
    K = len(nvec); masks (B, sum(nvec)) bool, laid out like the logits. log_prob and entropy are
    sums over the K dimensions; KL likewise (the dimensions are independent).

    Internally the logits are laid out as (B, K, max(nvec)), the padding set to MASKED_LOGIT, so
    every operation is one batched op whatever the nvec.
    """

    def __init__(self, nvec: Sequence[int], start: Sequence[int] | None = None) -> None:
        nvec = [int(n) for n in nvec]
        if not nvec or min(nvec) < 1:
            raise ValueError(f"MultiCategorical needs at least one dimension and every n >= 1, got {nvec}")
        self.nvec = nvec
        self.param_size = self.mask_size = sum(nvec)
        self.action_shape = (len(nvec),)
        self.action_dtype = torch.long
        self.width = max(nvec)
        self.uniform = all(n == self.width for n in nvec)
        # position of logit j of dimension k in the padded (K * width) layout
        self._slots = torch.tensor([k * self.width + j for k, n in enumerate(nvec) for j in range(n)])
        start = [0] * len(nvec) if start is None else [int(s) for s in start]
        self._start = torch.tensor(start, dtype=torch.long) if any(start) else None

    def params_from_network(self, out: tuple) -> tuple[torch.Tensor, torch.Tensor]:
        logits = out[0]  # rl_games' networks return a list of (B, n_k) logits, rlchain's one (B, sum n_k)
        return (torch.cat(list(logits), -1) if isinstance(logits, (list, tuple)) else logits), out[1]

    def _padded(self, flat: torch.Tensor, fill: float | bool) -> torch.Tensor:
        """(B, sum(nvec)) -> (B, K, width), padding entries = ``fill``."""
        b, k = flat.shape[0], len(self.nvec)
        if self.uniform:
            return flat.reshape(b, k, self.width)
        slots = self._slots.to(flat.device)
        out = flat.new_full((b, k * self.width), fill).index_copy(1, slots, flat)
        return out.view(b, k, self.width)

    def _log_softmax(self, params: torch.Tensor) -> torch.Tensor:
        """(B, K, width) per-dimension log-probabilities; padding has probability 0."""
        return torch.log_softmax(self._padded(params, _masked_logit(params.dtype)), -1)

    def sample(self, params: torch.Tensor) -> torch.Tensor:
        return _gumbel_argmax(self._padded(params, _masked_logit(params.dtype)))

    def mode(self, params: torch.Tensor) -> torch.Tensor:
        return self._padded(params, _masked_logit(params.dtype)).argmax(-1)

    @staticmethod
    def _gather(logp: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        return logp.gather(-1, actions.long().reshape(logp.shape[0], -1, 1)).squeeze(-1).sum(-1)

    @staticmethod
    def _entropy(logp: torch.Tensor) -> torch.Tensor:
        return -(logp.exp() * logp).sum((-2, -1))

    def log_prob(self, params: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        return self._gather(self._log_softmax(params), actions)

    def entropy(self, params: torch.Tensor) -> torch.Tensor:
        return self._entropy(self._log_softmax(params))

    def log_prob_and_entropy(self, params: torch.Tensor, actions: torch.Tensor
                             ) -> tuple[torch.Tensor, torch.Tensor]:
        logp = self._log_softmax(params)
        return self._gather(logp, actions), self._entropy(logp)

    def kl(self, old: torch.Tensor, new: torch.Tensor) -> torch.Tensor:
        old_logp, new_logp = self._log_softmax(old), self._log_softmax(new)
        return (old_logp.exp() * (old_logp - new_logp)).sum((-2, -1))

    def mask(self, params: torch.Tensor, masks: torch.Tensor, check: bool = True) -> torch.Tensor:
        """Invalid logits become MASKED_LOGIT; masks (B, sum(nvec)) are laid out like the logits.

        Each dimension of each row needs at least one True entry, else ActionMaskError.
        """
        out, masks = _apply_mask(params, masks, self.mask_size)
        if check:
            _no_valid_rows(self._padded(masks, False).any(-1))
        return out

    def to_env(self, actions: torch.Tensor) -> torch.Tensor:
        """(B, K) int64 indices shifted by the spaces' ``start``. The vecenv layer turns them into
        what the env takes (a tuple of per-dimension arrays for Tuple spaces)."""
        if self._start is None:
            return actions
        return actions + self._start.to(actions.device)


def sigma_std(raw: torch.Tensor, parametrization: str, min_sigma: float,
              logstd_bounds: tuple[float, float] | None) -> torch.Tensor:
    """The std from a sigma head's raw output, by rl_games 2.0's ``sigma_parametrization``: exp (any other
    name): exp(raw clamped to logstd_bounds) + min_sigma; softplus: softplus(raw) + min_sigma; linear:
    floor + softplus(raw - floor) with floor = max(min_sigma, 1e-3)."""
    if parametrization == "softplus":
        return torch.nn.functional.softplus(raw) + min_sigma
    if parametrization == "linear":
        floor = max(min_sigma, 1e-3)
        return floor + torch.nn.functional.softplus(raw - floor)
    if logstd_bounds is not None:
        raw = raw.clamp(logstd_bounds[0], logstd_bounds[1])
    std = raw.exp()
    return std + min_sigma if min_sigma > 0 else std


class BoxActions:
    """A Box's actions from [-1, 1] to [low, high] with clip_actions and finite bounds (``rescale``): PPO's, SAC's."""

    def __init__(self, space: gym.spaces.Box, clip_actions: bool) -> None:
        low = np.asarray(space.low, dtype=np.float64).reshape(-1)
        high = np.asarray(space.high, dtype=np.float64).reshape(-1)
        self.rescale = clip_actions and bool(np.isfinite(low).all() and np.isfinite(high).all())
        self._low = torch.as_tensor(low, dtype=torch.float32)
        self._high = torch.as_tensor(high, dtype=torch.float32)

    def to_env(self, actions: torch.Tensor) -> torch.Tensor:
        """With clip_actions: clip to [-1, 1] and rescale linearly to [low, high]."""
        if not self.rescale:
            return actions
        low, high = self._low.to(actions.device), self._high.to(actions.device)
        return low + (actions.clamp(-1.0, 1.0) + 1.0) * 0.5 * (high - low)


class DiagGaussian(BoxActions, Distribution):
    """Box(A): params are cat(mu, std) (B, 2A); the network's sigma is log-std or std by model."""

    continuous = True

    def __init__(self, space: gym.spaces.Box, sigma_is_logstd: bool, clip_actions: bool,
                 parametrization: str = "exp", min_sigma: float = 0.0,
                 logstd_bounds: tuple[float, float] | None = None) -> None:
        if parametrization not in ("exp", "softplus", "linear"):
            raise ValueError(f"params.network.space.continuous.sigma_parametrization: '{parametrization}' is not "
                             f"exp, softplus or linear")
        if not sigma_is_logstd and (parametrization != "exp" or min_sigma or logstd_bounds is not None):
            raise ValueError("params.network.space.continuous.sigma_parametrization / min_sigma / logstd_bounds "
                             "apply to model continuous_a2c_logstd (the sigma head's raw output), not continuous_a2c")
        self.parametrization = parametrization
        self.min_sigma = float(min_sigma)
        self.logstd_bounds = logstd_bounds
        self.action_shape = space.shape
        self.dim = int(np.prod(space.shape))
        self.param_size = 2 * self.dim
        self.action_dtype = torch.float32
        self.sigma_is_logstd = sigma_is_logstd
        self.clip_actions = clip_actions
        super().__init__(space, clip_actions)

    def params_from_network(self, out: tuple) -> tuple[torch.Tensor, torch.Tensor]:
        mu, sigma, value = out[0], out[1], out[2]
        return torch.cat([mu, self.std_of(sigma) if self.sigma_is_logstd else sigma], -1), value

    def std_of(self, raw: torch.Tensor) -> torch.Tensor:
        """The std from the sigma head's raw output (model continuous_a2c_logstd): :func:`sigma_std`."""
        return sigma_std(raw, self.parametrization, self.min_sigma, self.logstd_bounds)

    def raw_sigma(self, std: float) -> float:
        """The raw sigma-head value whose std is ``std`` (the inverse of :meth:`std_of`; ``--sigma``)."""
        if not self.sigma_is_logstd:
            return std
        floor = max(self.min_sigma, 1e-3) if self.parametrization == "linear" else self.min_sigma
        if std <= floor:
            raise ValueError(f"--sigma {std}: must be above the std floor {floor} (min_sigma)")
        if self.parametrization == "exp":
            return math.log(std - self.min_sigma)
        excess = std - floor  # softplus(x) = excess -> x = log(expm1(excess))
        raw = math.log(math.expm1(excess))
        return raw + floor if self.parametrization == "linear" else raw

    def _split(self, params: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return params[..., : self.dim], params[..., self.dim:]

    def sample(self, params: torch.Tensor) -> torch.Tensor:
        mu, std = self._split(params)
        return mu + std * torch.randn_like(mu)

    def mode(self, params: torch.Tensor) -> torch.Tensor:
        return self._split(params)[0]

    def log_prob(self, params: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        mu, std = self._split(params)
        z = (actions - mu) / std
        return (-0.5 * z * z - std.log() - 0.5 * math.log(2 * math.pi)).sum(-1)

    def entropy(self, params: torch.Tensor) -> torch.Tensor:
        std = self._split(params)[1]
        return (0.5 + 0.5 * math.log(2 * math.pi) + std.log()).sum(-1)

    def kl(self, old: torch.Tensor, new: torch.Tensor) -> torch.Tensor:
        mu0, std0 = self._split(old)
        mu1, std1 = self._split(new)
        return (torch.log(std1 / std0) + (std0.square() + (mu0 - mu1).square()) / (2 * std1.square())
                - 0.5).sum(-1)

    def bounds_loss(self, params: torch.Tensor, kind: str) -> torch.Tensor:
        mu = self._split(params)[0]
        if kind == "regularisation":
            return mu.square().sum(-1)
        soft = 1.1
        return ((mu - soft).clamp_min(0).square() + (mu + soft).clamp_max(0).square()).sum(-1)

    def mask(self, params: torch.Tensor, masks: torch.Tensor) -> torch.Tensor:
        raise ActionMaskError("params.config.use_action_masks: action masks need discrete or multi-discrete "
                              "actions; this env has continuous (Box) actions")


def multi_discrete_dims(space: gym.Space) -> tuple[list[int], list[int]] | None:
    """(nvec, start) of a MultiDiscrete, MultiBinary or Tuple-of-Discrete space, else None."""
    if isinstance(space, gym.spaces.MultiDiscrete):
        start = getattr(space, "start", np.zeros_like(space.nvec))
        return [int(n) for n in np.ravel(space.nvec)], [int(s) for s in np.ravel(start)]
    if isinstance(space, gym.spaces.MultiBinary):
        n = int(np.prod(space.shape))
        return [2] * n, [0] * n
    if isinstance(space, gym.spaces.Tuple) and space.spaces and \
            all(isinstance(s, gym.spaces.Discrete) for s in space.spaces):
        return [int(s.n) for s in space.spaces], [int(s.start) for s in space.spaces]
    return None


def actions_num(space: gym.Space) -> int:
    """Width of the network's action head for ``space``: n, sum(nvec) or prod(Box shape)."""
    if isinstance(space, gym.spaces.Discrete):
        return int(space.n)
    dims = multi_discrete_dims(space)
    if dims is not None:
        return sum(dims[0])
    return int(np.prod(space.shape))


MULTI_DISCRETE_MODELS = ("multi_discrete_a2c",)


def make_distribution(model_name: str, space: gym.Space, clip_actions: bool, network: Any = None) -> Distribution:
    """The distribution a model preset uses for ``space``; a clear error on a mismatch. A continuous head's
    ``sigma_parametrization`` / ``min_sigma`` / ``logstd_bounds`` come from ``network``'s attributes."""
    multi = multi_discrete_dims(space)
    if isinstance(space, gym.spaces.Discrete):
        if model_name not in ("discrete_a2c",):
            raise ValueError(f"params.model.name: '{model_name}' does not fit the env's Discrete({space.n}) "
                             f"actions; use discrete_a2c")
        return Categorical(int(space.n), int(space.start))
    if multi is not None:
        if model_name not in MULTI_DISCRETE_MODELS:
            raise ValueError(f"params.model.name: '{model_name}' does not fit the env's {space} actions; "
                             f"use multi_discrete_a2c")
        return MultiCategorical(*multi)
    if isinstance(space, gym.spaces.Box):
        if model_name not in ("continuous_a2c_logstd", "continuous_a2c"):
            raise ValueError(f"params.model.name: '{model_name}' needs discrete actions, the env has "
                             f"Box{space.shape}; use continuous_a2c_logstd")
        return DiagGaussian(space, sigma_is_logstd=model_name == "continuous_a2c_logstd", clip_actions=clip_actions,
                            parametrization=getattr(network, "sigma_parametrization", "exp"),
                            min_sigma=getattr(network, "min_sigma", 0.0),
                            logstd_bounds=getattr(network, "logstd_bounds", None))
    raise ValueError(f"action space {space} is not supported (Discrete, MultiDiscrete, MultiBinary, "
                     f"Tuple of Discrete, Box)")
