"""``config.torch_compile`` applied: compile a model's network in place."""

from __future__ import annotations

import torch

from rlchain.config.compile import CompileSpec, parse_compile


def compile_model(model: torch.nn.Module, setting: object) -> CompileSpec | None:
    """Compile ``model.a2c_network`` (and a central value network, if any) as ``setting`` says."""
    spec = parse_compile(setting)
    if spec is None:
        return None
    compile_network(model.a2c_network, spec.mode, spec.backend)
    critic = getattr(model, "central_value", None)
    if critic is not None:
        compile_network(critic.a2c_network, spec.critic_mode, spec.backend)
    return spec


def compile_network(module: torch.nn.Module, mode: str, backend: str) -> None:
    """Compile ``module.forward`` in place; parameter names (and so checkpoints) do not change."""
    options = {"mode": mode} if backend == "inductor" else {}
    module.forward = torch.compile(module.forward, backend=backend, **options)
