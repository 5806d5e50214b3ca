"""One actor-critic model for every action space: network + distribution + normalizers.

rl_games' model names (``discrete_a2c``, ``continuous_a2c_logstd``, ``continuous_a2c``) are presets
that choose the distribution (see :func:`rlchain.models.distributions.make_distribution`).
"""

from __future__ import annotations

import inspect
from typing import Any

import torch
import torch.nn as nn

from rlchain.models.base import ValueModel, value_normalizer
from rlchain.models.distributions import Distribution
from rlchain.models.normalization import obs_normalizer
from rlchain.networks.direct import DirectPass


class ActorCritic(ValueModel):
    """Wraps a network (rl_games output tuple) into act / evaluate calls.

    Values are in the normalized space when ``normalize_value`` is on; ``denorm_value`` maps
    them back to returns. Observations are normalized here, once, with frozen statistics:
    :meth:`update_normalizers` folds a batch in after an update.
    """

    def __init__(self, network: nn.Module, dist: Distribution, obs_shape: tuple[int, ...],
                 value_size: int, normalize_input: bool, normalize_value: bool,
                 use_action_masks: bool = False, value_normalizer_kind: str = "rl_games",
                 obs_normalizer_kind: str = "rl_games", obs_normalizer_exclude: tuple[str, ...] = (),
                 bptt_length: int | None = None) -> None:
        super().__init__()
        # rl_games' model: its normalizers, then the network (the state dict in rl_games' order)
        self.value_mean_std = value_normalizer(value_size, normalize_value, value_normalizer_kind)
        self.running_mean_std = obs_normalizer(obs_shape, obs_normalizer_kind, tuple(obs_normalizer_exclude)) \
            if normalize_input else None
        self.a2c_network = network
        self.dist = dist
        self.fold_values = value_normalizer_kind == "rl_games"
        self.use_action_masks = use_action_masks
        is_rnn = getattr(network, "is_rnn", None)
        self.is_rnn = bool(is_rnn()) if callable(is_rnn) else False
        self.sized_states = self.is_rnn and _takes_arguments(network.get_default_rnn_state)
        self.num_states = len(self.initial_state(1)) if self.is_rnn else 0
        self.bptt_length = bptt_length  # truncated BPTT inside training sequences (config.bptt_length)

    def forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """obs (B, *obs_shape) -> (dist params (B, P), value (B, value_size)); stateless, no masks."""
        params, value, _ = self.evaluate(obs)
        return params, value

    def evaluate(self, obs: torch.Tensor, states: tuple[torch.Tensor, ...] | None = None,
                 resets: torch.Tensor | None = None, seq_length: int = 1,
                 action_masks: torch.Tensor | None = None, actions: torch.Tensor | None = None
                 ) -> tuple[torch.Tensor, torch.Tensor, tuple[torch.Tensor, ...] | None]:
        """The full forward pass: (dist params (B, P), value (B, value_size), new RNN states).

        For an RNN, obs rows come in ``seq_length`` blocks per sequence (see RecurrentLayer),
        ``states`` are the states entering each sequence and ``resets`` (B,) marks episode starts.
        ``action_masks`` (B, mask_size) bool restricts the distribution to valid actions. The network's input
        dict also carries rl_games' ``is_train`` (a gradient is being taken) and ``prev_actions`` (``actions``,
        the batch's actions in a training pass; None otherwise).
        """
        inputs: dict = {"obs": self.preprocess(obs), "is_train": torch.is_grad_enabled(), "prev_actions": actions}
        if self.is_rnn:  # states may carry a central value's after the model's own: take ours
            states = tuple(states[:self.num_states]) if states else self.initial_state(obs.shape[0] // seq_length,
                                                                                       obs.device)
            inputs.update(rnn_states=states, dones=resets, seq_length=seq_length,
                          bptt_len=self.bptt_length if seq_length > 1 else None)
        out = self.a2c_network(inputs)
        params, value = self.dist.params_from_network(out)
        if action_masks is not None:
            params = self.dist.mask(params, action_masks)
        new_states = tuple(out[-1]) if self.is_rnn and out[-1] is not None else None
        return params, value, new_states

    def aux_losses(self) -> Any:
        """The network's auxiliary losses from its last forward pass (rl_games' ``get_aux_loss()``:
        a dict of scalar tensors, or None); None when the network has no such method. Unchecked:
        :func:`rlchain.algos.core.losses.aux_loss_terms` validates them."""
        get_aux_loss = getattr(self.a2c_network, "get_aux_loss", None)
        return get_aux_loss() if callable(get_aux_loss) else None

    def initial_state(self, batch: int, device: torch.device | None = None) -> tuple[torch.Tensor, ...]:
        """Zero RNN states for ``batch`` envs, each (layers, batch, units); empty without an RNN."""
        if not self.is_rnn:
            return ()
        if self.sized_states:
            return tuple(self.a2c_network.get_default_rnn_state(batch, device))
        # rl_games' get_default_rnn_state() takes no arguments: zeros of its layout, sized for ``batch``
        return tuple(torch.zeros(s.shape[0], batch, *s.shape[2:], dtype=s.dtype, device=device)
                     for s in self.a2c_network.get_default_rnn_state())

    @torch.inference_mode()
    def act(self, obs: torch.Tensor, deterministic: bool = False, states: tuple | None = None,
            action_masks: torch.Tensor | None = None) -> dict[str, torch.Tensor]:
        """Rollout step: actions, their log-probs, raw-scale values, the distribution params and
        (for an RNN) the states after this step under ``"states"``."""
        direct = self.direct_pass()
        out = direct(self.preprocess(obs)) if direct is not None else None
        if out is None:
            params, value, new_states = self.evaluate(obs, states, action_masks=action_masks)
        else:  # evaluate's pass without nn.Module's call machinery: the same floats
            params, value = self.dist.params_from_network(out)
            if action_masks is not None:
                params = self.dist.mask(params, action_masks)
            new_states = None
        actions = self.dist.mode(params) if deterministic else self.dist.sample(params)
        return {"actions": actions, "log_probs": self.dist.log_prob(params, actions),
                "values": self.denorm_value(value), "params": params, "states": new_states}

    def direct_pass(self) -> DirectPass | None:
        """The network's :class:`DirectPass` when it is a plain MLP actor-critic (made again when the network
        is replaced), else None."""
        network = self.a2c_network
        direct = self.__dict__.get("_direct")
        if direct is None or direct.network is not network:
            direct = self.__dict__["_direct"] = DirectPass(network)
        return direct if direct.plain else None

    @torch.inference_mode()
    def value(self, obs: torch.Tensor, states: tuple | None = None) -> torch.Tensor:
        """Raw-scale state values (B, value_size), given the RNN states entering this step."""
        return self.denorm_value(self.evaluate(obs, states)[1])

    def override_sigma(self, sigma: float) -> None:
        """``--sigma``: set a fixed (input-independent) sigma to a constant standard deviation."""
        param = getattr(self.a2c_network, "sigma", None)
        if not isinstance(param, nn.Parameter):
            raise ValueError("--sigma needs a continuous policy with fixed_sigma: True")
        raw_sigma = getattr(self.dist, "raw_sigma", None)  # the inverse of the std parametrization
        value = raw_sigma(float(sigma)) if callable(raw_sigma) else sigma
        with torch.no_grad():
            param.fill_(float(value))


def _takes_arguments(method: Any) -> bool:
    """Whether ``method`` accepts (batch, device): rlchain's get_default_rnn_state does, rl_games' takes none."""
    try:
        params = inspect.signature(method).parameters.values()
    except (TypeError, ValueError):
        return True
    return any(p.kind in (p.VAR_POSITIONAL, p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params)
