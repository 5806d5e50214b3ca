"""PPO's minibatch step with its gradients written out: the plain case's forward pass without a graph, then the
backward pass from the loss's analytic gradients with respect to the network's outputs.

On a CPU the minibatch step of a small network is dominated by per-op overhead, not arithmetic: autograd records
about 90 ops of the forward pass and loss and replays about 150 backward nodes for the few matrix products of a
two-layer MLP. Where :func:`analytic_step` finds the plain case, :func:`rlchain.algos.ppo.loss.ppo_loss` runs the
network's layers through :class:`~rlchain.networks.direct_backward.DirectBackward` and its losses on tensors that
take no gradient (the same values, every statistic the same floats), computes the loss's gradients with respect to
the network's outputs from the terms' derivatives (:func:`~rlchain.algos.core.losses.policy_loss_grad`,
:func:`~rlchain.algos.core.losses.value_loss_grad`, the distribution's
:mod:`~rlchain.models.distribution_grads`), and :meth:`AnalyticStep.attach` hands autograd a loss whose one
backward node runs the network's written-out backward. The gradients equal autograd's up to float rounding.

The plain case: a CPU minibatch of flat tensor observations with a gradient being taken, not under
``torch.compile`` (``compile_update`` compiles autograd's path), no autocast, PPO's clipped
surrogate without the smooth clamp, the value loss trained, no action masks or row weights, and a network and
distribution both covered (a plain MLP actor-critic with relu / tanh / elu / identity activations; a categorical,
or a Gaussian whose std is exp(sigma) or sigma). Everything else takes autograd's path.
"""

from __future__ import annotations

from collections.abc import Callable

import torch

from rlchain.algos.core.losses import policy_loss
from rlchain.algos.core.storage import Batch
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distribution_grads import CategoricalGrads, GaussianGrads, analytic_grads
from rlchain.networks.direct_backward import DirectBackward, Tape, direct_backward


class AnalyticStep:
    """A model's network run forward without a graph (:meth:`forward`) and a loss whose backward is written out
    (:meth:`attach`); ``grads`` the distribution's derivatives."""

    def __init__(self, network: DirectBackward, grads: GaussianGrads | CategoricalGrads) -> None:
        self.network = network
        self.grads = grads

    def forward(self, x: torch.Tensor) -> tuple[tuple, Tape] | None:
        """(the network's output tuple, the tape) for preprocessed ``x``; None where a hook is set."""
        return self.network.forward(x)

    def attach(self, loss: torch.Tensor, tape: Tape, output_grads: tuple[torch.Tensor, ...]) -> torch.Tensor:
        """``loss`` (0-d, no graph) as a tensor whose backward gives the network's parameters the gradients
        that ``output_grads`` (d loss / d each network output) imply."""
        return _WrittenOutBackward.apply(loss, self.network, tape, output_grads, *self.network.parameters)


def analytic_step(model: ActorCritic, batch: Batch, surrogate: Callable, train_critic: bool,
                  amp_dtype: torch.dtype | None, smooth_clamp: bool) -> AnalyticStep | None:
    """The model's :class:`AnalyticStep` for this minibatch's loss, or None outside the plain case."""
    if not (torch.is_grad_enabled() and not torch.compiler.is_compiling() and amp_dtype is None and train_critic
            and surrogate is policy_loss
            and not smooth_clamp and batch.action_masks is None and batch.weights is None and not model.is_rnn
            and type(batch.obs) is torch.Tensor and batch.obs.device.type == "cpu"):
        return None
    direct = model.direct_pass()
    network = direct_backward(direct) if direct is not None else None
    grads = analytic_grads(model.dist) if network is not None else None
    return AnalyticStep(network, grads) if grads is not None else None


class _WrittenOutBackward(torch.autograd.Function):
    """The loss as computed, with one backward node: the output gradients scaled by the incoming gradient, then
    the network's written-out backward, one gradient per parameter."""

    @staticmethod
    def forward(ctx, loss: torch.Tensor, network: DirectBackward, tape: Tape, output_grads: tuple,
                *parameters: torch.Tensor) -> torch.Tensor:
        ctx.step = (network, tape, output_grads)  # autograd's place for what backward needs beyond tensors
        return loss.clone()

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> tuple:
        network, tape, output_grads = ctx.step
        ctx.step = None  # the activations are not needed again
        return (None, None, None, None, *network.backward(tape, tuple(g * grad for g in output_grads)))
