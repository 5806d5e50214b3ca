"""APG: analytic policy gradients through a differentiable tensor env (truncated backpropagation)."""
