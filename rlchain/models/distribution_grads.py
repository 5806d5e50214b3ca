"""The gradients of a distribution's log-prob, entropy and KL, written out, with respect to the network's outputs.

PPO's analytic minibatch step (:mod:`rlchain.algos.ppo.analytic_step`) needs, for the loss it computed without a
graph, the gradient of ``sum_i g_logp_i * log_prob_i + g_entropy * sum_i entropy_i + g_kl * sum_i KL(ref_i ||
current_i)`` with respect to the outputs the network handed the distribution (:meth:`params_from_network`'s
inputs). Each class here does that for one distribution, with the derivatives of the formulas in
:mod:`rlchain.models.distributions` (the same values as autograd's up to float rounding). :func:`analytic_grads`
finds the one for a distribution, or None where the distribution or its std parametrization is not covered.
"""

from __future__ import annotations

import torch

from rlchain.models.distributions import Categorical, DiagGaussian, Distribution


class GaussianGrads:
    """:class:`DiagGaussian`: params ``cat(mu, std)``, the network's outputs (mu, sigma) with sigma the log-std
    (``exp`` parametrization, no floor or bounds: std = exp(sigma), so d std / d sigma = std) or the std itself."""

    def __init__(self, dist: DiagGaussian) -> None:
        self.dim = dist.dim
        self.sigma_is_logstd = dist.sigma_is_logstd

    def network_grads(self, params: torch.Tensor, actions: torch.Tensor, g_log_prob: torch.Tensor,
                      g_entropy: torch.Tensor, reference: torch.Tensor | None, g_kl: torch.Tensor | None,
                      bounds: tuple[str, float] | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """(d / d mu, d / d sigma), each (B, A), of the weighted sum above; ``g_log_prob`` (B,), ``g_entropy`` and
        ``g_kl`` 0-d (``reference`` None: no KL term); ``bounds`` (the bounds loss's kind, its weight) adds that
        weight times the sum of :meth:`DiagGaussian.bounds_loss` over the rows."""
        mu, std = params[:, :self.dim], params[:, self.dim:]
        inv_std = std.reciprocal()
        z = (actions - mu) * inv_std
        g = g_log_prob.unsqueeze(-1) * inv_std
        g_mu = g * z  # log N(a; mu, std) = -z^2 / 2 - log std - log(2 pi) / 2, z = (a - mu) / std
        g_std = torch.addcmul(g_entropy * inv_std, g, z * z - 1.0)  # entropy: sum log std + const
        if reference is not None:  # KL = log(std / std0) + (std0^2 + (mu0 - mu)^2) / (2 std^2) - 1/2
            dmu = mu - reference[:, :self.dim]
            inv_var = inv_std.square()
            g_mu = torch.addcmul(g_mu, dmu * inv_var, g_kl)
            spread = (reference[:, self.dim:].square() + dmu.square()).mul_(inv_var)
            g_std = torch.addcmul(g_std, (1.0 - spread).mul_(inv_std), g_kl)
        if bounds is not None:
            kind, weight = bounds
            if kind == "regularisation":  # sum mu^2
                g_mu = g_mu + (2.0 * weight) * mu
            else:  # sum (mu - 1.1)_+^2 + (mu + 1.1)_-^2
                g_mu = g_mu + (2.0 * weight) * ((mu - 1.1).clamp_min(0) + (mu + 1.1).clamp_max(0))
        return g_mu, g_std * std if self.sigma_is_logstd else g_std


class CategoricalGrads:
    """:class:`Categorical`: params are the logits, the network's one policy output."""

    def network_grads(self, params: torch.Tensor, actions: torch.Tensor, g_log_prob: torch.Tensor,
                      g_entropy: torch.Tensor, reference: torch.Tensor | None, g_kl: torch.Tensor | None,
                      bounds: tuple[str, float] | None = None) -> tuple[torch.Tensor]:
        """(d / d logits,) (B, n) of the weighted sum above (a categorical's bounds loss is zero: ``bounds`` adds
        nothing)."""
        logp = torch.log_softmax(params, -1)
        p = logp.exp()
        g_lp = g_log_prob.unsqueeze(-1)
        g = (-g_lp) * p  # d log p_a / d logits = onehot(a) - p
        g.scatter_add_(-1, actions.long().unsqueeze(-1), g_lp)
        entropy = (p * logp).sum(-1, keepdim=True).neg_()  # d H / d logits = -p (log p + H)
        g = torch.addcmul(g, p * (logp + entropy), g_entropy.neg())
        if reference is not None:  # d KL(ref || p) / d logits = p - p_ref
            g = torch.addcmul(g, p - torch.softmax(reference, -1), g_kl)
        return (g,)


def analytic_grads(dist: Distribution) -> GaussianGrads | CategoricalGrads | None:
    """The written-out gradients for ``dist`` (its exact type), or None where they are not covered: another
    distribution, a subclass, or a Gaussian whose std is not exp(sigma) or sigma itself."""
    if type(dist) is Categorical:
        return CategoricalGrads()
    if type(dist) is DiagGaussian and (not dist.sigma_is_logstd or (
            dist.parametrization == "exp" and dist.min_sigma == 0 and dist.logstd_bounds is None)):
        return GaussianGrads(dist)
    return None
