"""Adam's fused step called directly: the kernel torch's ``Adam(fused=True).step()`` runs, with the same arguments,
without the wrapper's per-call bookkeeping (profiler ranges, hook lookups, the per-parameter state checks of
``_init_group``, regrouping the tensors by device). A PPO update makes hundreds of steps on small networks, where
that bookkeeping cost as much as the kernel itself (about 0.2 ms a step against 0.2 ms on the tuned Pendulum's
two [256, 256] MLPs, 2-core CPU).

Only the plain case is taken: one parameter group of one device and dtype, ``fused``, no amsgrad, maximize,
capturable, differentiable or decoupled weight decay, a float lr, every parameter with a dense gradient and
its state created (torch's first step creates it), and no step hooks or wrapper on ``step``. Anything else
returns False and the caller steps as usual, so the results are torch's either way.
"""

from __future__ import annotations

import torch
from torch.optim import optimizer as torch_optimizer

_OFF_FLAGS = ("amsgrad", "maximize", "capturable", "differentiable", "decoupled_weight_decay")


def fused_adam_step(optimizer: torch.optim.Optimizer) -> bool:
    """One step of ``optimizer`` through ``torch._fused_adam_``, as ``optimizer.step()`` would make it; False
    (nothing done) where the plain case does not hold."""
    if type(optimizer) is not torch.optim.Adam or len(optimizer.param_groups) != 1 or "step" in vars(optimizer) \
            or optimizer._optimizer_step_pre_hooks or optimizer._optimizer_step_post_hooks \
            or torch_optimizer._global_optimizer_pre_hooks or torch_optimizer._global_optimizer_post_hooks:
        return False
    group = optimizer.param_groups[0]
    lr = group["lr"]
    if not group.get("fused") or any(group.get(flag) for flag in _OFF_FLAGS) or isinstance(lr, torch.Tensor):
        return False
    params = group["params"]
    if not params:
        return False
    state = optimizer.state
    grads, exp_avgs, exp_avg_sqs, steps = [], [], [], []
    device, dtype = params[0].device, params[0].dtype
    for p in params:
        grad, entry = p.grad, state.get(p)
        if grad is None or grad.is_sparse or not entry or p.device != device or p.dtype != dtype \
                or p.is_complex():
            return False
        grads.append(grad)
        exp_avgs.append(entry["exp_avg"])
        exp_avg_sqs.append(entry["exp_avg_sq"])
        steps.append(entry["step"])
    beta1, beta2 = group["betas"]
    with torch.no_grad():
        torch._foreach_add_(steps, 1)
        torch._fused_adam_(params, grads, exp_avgs, exp_avg_sqs, [], steps, amsgrad=False, lr=lr,
                           beta1=float(beta1), beta2=float(beta2), weight_decay=group["weight_decay"],
                           eps=group["eps"], maximize=False, grad_scale=None, found_inf=None)
    return True
