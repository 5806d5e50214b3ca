"""The plain MLP actor-critic's backward pass written out: its parameters' gradients from its outputs' gradients.

PPO's minibatch step on a CPU spends most of its time on small dispatcher ops, not arithmetic: on a 128-row
minibatch autograd records and replays about 150 nodes (transposes, views, accumulations) around the few matrix
products a two-layer MLP needs. For a network :class:`~rlchain.networks.direct.DirectPass` runs (Linear layers and
activations, the built-in heads) whose activations all have a known derivative here (relu, tanh, elu, identity),
:class:`DirectBackward` runs the same layers' forward methods without a graph, keeping what each layer's gradient
needs (a Linear's input, an activation's input or output), and then computes the gradients autograd would: the
same formulas (``threshold_backward``, ``tanh_backward``, ``elu_backward``, a Linear's three products), the
gradients of a trunk's input summed over the heads that read it. The forward outputs are the same floats as the
module's own call; the gradients the same up to float rounding (sums taken in another order).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn as nn

from rlchain.networks.direct import DirectPass, _hooked
from rlchain.networks.layers import NARROW_INPUTS, Linear

_DERIVATIVES = (nn.ReLU, nn.Tanh, nn.ELU, nn.Identity)
"""Activation types with a written-out derivative (an ELU only out of place)."""


@dataclass
class Tape:
    """What one forward pass kept for its backward: per trunk, (layer, the tensor its gradient needs) in order;
    the heads' inputs (actor's, critic's) and outputs (the activations' derivatives read them)."""

    trunks: list[list[tuple[nn.Module, torch.Tensor]]]
    actor_out: torch.Tensor
    critic_out: torch.Tensor
    head_outputs: list[tuple[nn.Module, torch.Tensor, torch.Tensor]]


class DirectBackward:
    """A :class:`DirectPass`'s network run forward with its backward written out.

    :attr:`parameters` lists the network's trainable parameters in the order :meth:`backward` returns their
    gradients; :attr:`usable` is False where the network is not covered (then nothing here runs).
    """

    def __init__(self, direct: DirectPass) -> None:
        self.direct = direct
        self.usable = False
        if not direct.plain:
            return
        trunks = [direct.actor] + ([direct.critic] if direct.critic is not None else [])
        activations = [m for trunk in trunks for m in trunk if not isinstance(m, nn.Linear)] + list(direct.acts)
        linears = [m for trunk in trunks for m in trunk if isinstance(m, nn.Linear)] + list(direct.heads)
        if any(type(a) not in _DERIVATIVES or (type(a) is nn.ELU and a.inplace) for a in activations) \
                or any(m.bias is None for m in linears):
            return
        self.trunks = trunks
        params = [p for m in linears for p in (m.weight, m.bias)]
        if direct.fixed_sigma:
            params.append(direct.network.sigma)
        if not all(p.requires_grad for p in params):
            return
        self.parameters = params
        self.usable = True

    def forward(self, x: torch.Tensor) -> tuple[tuple, Tape] | None:
        """(the network's output tuple for preprocessed ``x``, as its own call gives it; the tape), computed
        without a graph; None when a hook is set or a module was replaced (the caller runs autograd's pass)."""
        direct = self.direct
        if _hooked(direct.modules) or any(live != built for live, built in direct.children):
            return None
        with torch.no_grad():
            x = x if x.dim() == 2 else x.flatten(1)
            kept = []
            outs = []
            for trunk in self.trunks:
                tape, h = [], x
                for layer in trunk:
                    out = _linear_forward(layer, h) if isinstance(layer, nn.Linear) else layer.forward(h)
                    tape.append((layer, h if isinstance(layer, (nn.Linear, nn.ELU)) else out))
                    h = out
                kept.append(tape)
                outs.append(h)
            a_out, c_out = outs[0], outs[-1]
            heads, acts = direct.heads, direct.acts
            head_outputs = []

            def head(linear: nn.Module | None, act: nn.Module, h: torch.Tensor | None) -> torch.Tensor:
                pre = _linear_forward(linear, h) if linear is not None else direct.network.sigma
                out = act.forward(pre)
                head_outputs.append((act, pre, out))
                return out

            value = head(heads[0], acts[0], c_out)
            if not direct.continuous:
                return (_linear_forward(heads[1], a_out), value, None), Tape(kept, a_out, c_out, head_outputs)
            mu = head(heads[1], acts[1], a_out)
            sigma = head(None, acts[2], None).expand_as(mu) if direct.fixed_sigma else head(heads[2], acts[2], a_out)
            return (mu, sigma, value, None), Tape(kept, a_out, c_out, head_outputs)

    def backward(self, tape: Tape, grads: tuple[torch.Tensor, ...]) -> list[torch.Tensor]:
        """The gradients of :attr:`parameters` given the gradients of the network's outputs: (mu, sigma, value)
        for a Gaussian, (logits, value) for a categorical, each shaped as the output."""
        direct = self.direct
        heads, acts = direct.heads, direct.acts
        if direct.continuous:
            g_mu, g_sigma, g_value = grads
            g_mu = _activation_grad(acts[1], g_mu, *tape.head_outputs[1][1:])
            if direct.fixed_sigma:  # one parameter vector expanded over the rows: its gradient is their sum
                g_sigma = g_sigma.sum(0)
            g_sigma = _activation_grad(acts[2], g_sigma, *tape.head_outputs[2][1:])
            actor_heads = [(heads[1], g_mu)] + ([] if direct.fixed_sigma else [(heads[2], g_sigma)])
        else:
            g_logits, g_value = grads
            actor_heads = [(heads[1], g_logits)]
        g_value = _activation_grad(acts[0], g_value, *tape.head_outputs[0][1:])
        head_grads: dict[int, list[torch.Tensor]] = {}
        g_actor = None
        for linear, g in actor_heads:
            head_grads[id(linear)] = _linear_param_grads(linear, g, tape.actor_out)
            g_actor = g.mm(linear.weight) if g_actor is None else torch.addmm(g_actor, g, linear.weight)
        head_grads[id(heads[0])] = _linear_param_grads(heads[0], g_value, tape.critic_out)
        if direct.critic is None:
            g_actor = torch.addmm(g_actor, g_value, heads[0].weight)
            trunk_grads = [_trunk_grads(tape.trunks[0], g_actor)]
        else:
            trunk_grads = [_trunk_grads(tape.trunks[0], g_actor),
                           _trunk_grads(tape.trunks[1], g_value.mm(heads[0].weight))]
        out = [g for grads_of_trunk in trunk_grads for g in grads_of_trunk]
        for linear in heads:
            out += head_grads[id(linear)]
        if direct.fixed_sigma:
            out.append(g_sigma)
        return out


def direct_backward(direct: DirectPass) -> DirectBackward | None:
    """``direct``'s :class:`DirectBackward` (made once per pass), None where it does not cover the network."""
    made = direct.__dict__.get("_backward")
    if made is None:
        made = direct.__dict__["_backward"] = DirectBackward(direct)
    return made if made.usable else None


def _linear_forward(linear: nn.Module, x: torch.Tensor) -> torch.Tensor:
    """A Linear's output as its forward gives it while a gradient is taken: rlchain's :class:`Linear` on a narrow
    input multiplies by a contiguous copy of the transposed weight (other layers: their own forward)."""
    if type(linear) is Linear and linear.in_features <= NARROW_INPUTS:
        return torch.addmm(linear.bias, x, linear.weight.t().contiguous())
    return linear.forward(x)


def _activation_grad(act: nn.Module, grad: torch.Tensor, pre: torch.Tensor, out: torch.Tensor) -> torch.Tensor:
    """The gradient of an activation's input from its output's, as autograd's derivative of it computes it."""
    kind = type(act)
    if kind is nn.ReLU:
        return torch.ops.aten.threshold_backward(grad, out, 0)
    if kind is nn.Tanh:
        return torch.ops.aten.tanh_backward(grad, out)
    if kind is nn.ELU:
        return torch.ops.aten.elu_backward(grad, act.alpha, 1, 1, False, pre)
    return grad


def _linear_param_grads(linear: nn.Module, grad: torch.Tensor, inputs: torch.Tensor) -> list[torch.Tensor]:
    """[weight gradient, bias gradient] of a Linear from its output's gradient (B, out) and its input (B, in);
    a narrow input takes ``(x.t() @ g).t()``, which MKL runs far faster than ``g.t() @ x`` (the same sum)."""
    if linear.in_features <= NARROW_INPUTS:
        weight = inputs.t().mm(grad).t()
    else:
        weight = grad.t().mm(inputs)
    return [weight, grad.sum(0)]


def _trunk_grads(tape: list[tuple[nn.Module, torch.Tensor]], grad: torch.Tensor) -> list[torch.Tensor]:
    """The parameter gradients of one trunk (weight, bias per Linear, in layer order) from its output's gradient."""
    out: list[list[torch.Tensor]] = []
    for i in range(len(tape) - 1, -1, -1):
        layer, kept = tape[i]
        if isinstance(layer, nn.Linear):
            out.append(_linear_param_grads(layer, grad, kept))
            if i > 0:  # the trunk's input (the observations) takes no gradient
                grad = grad.mm(layer.weight)
        else:
            grad = _activation_grad(layer, grad, kept, kept)
    return [g for pair in reversed(out) for g in pair]
