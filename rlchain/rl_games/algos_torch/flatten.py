"""rl_games' ``algos_torch.flatten.TracingAdapter``: a module taking and returning flat tuples of tensors,
so ``torch.jit.trace`` / ``torch.onnx.export`` can take a model whose inputs or outputs are nested (rl_games'
ONNX recipe: ``TracingAdapter(ModelWrapper(agent.model), {'obs': ..., 'rnn_states': ...},
allow_non_tensor=True)``)."""

from __future__ import annotations

from typing import Any

import torch
from torch import nn


def flatten(value: Any, allow_non_tensor: bool) -> tuple[list[torch.Tensor], Any]:
    """The tensors of a nest of dicts, lists and tuples, in order, and its structure (a schema that
    :func:`unflatten` fills back). Other leaves (None, numbers) are kept in the schema when allowed."""
    if isinstance(value, torch.Tensor):
        return [value], ("tensor",)
    if isinstance(value, dict):
        tensors, schemas = [], []
        for key in value:
            flat, schema = flatten(value[key], allow_non_tensor)
            tensors += flat
            schemas.append((key, schema))
        return tensors, ("dict", tuple(schemas))
    if isinstance(value, (list, tuple)):
        tensors, schemas = [], []
        for item in value:
            flat, schema = flatten(item, allow_non_tensor)
            tensors += flat
            schemas.append(schema)
        return tensors, ("list" if isinstance(value, list) else "tuple", tuple(schemas))
    if not allow_non_tensor:
        raise ValueError(f"TracingAdapter: a {type(value).__name__} among the tensors (allow_non_tensor=False)")
    return [], ("const", value)


def unflatten(tensors: list[torch.Tensor], schema: Any) -> Any:
    """The nest :func:`flatten` took apart, from its tensors (consumed from the front) and schema."""
    kind = schema[0]
    if kind == "tensor":
        return tensors.pop(0)
    if kind == "const":
        return schema[1]
    if kind == "dict":
        return {key: unflatten(tensors, sub) for key, sub in schema[1]}
    items = [unflatten(tensors, sub) for sub in schema[1]]
    return items if kind == "list" else tuple(items)


class TracingAdapter(nn.Module):
    """``model(inputs)`` as ``adapter(*flattened_inputs) -> tuple of tensors`` (non-tensor outputs dropped
    when ``allow_non_tensor``). ``inputs`` is the one argument the model takes (a dict, a tensor, ...)."""

    def __init__(self, model: nn.Module, inputs: Any, allow_non_tensor: bool = False) -> None:
        super().__init__()
        self.model = model
        self.allow_non_tensor = allow_non_tensor
        flat, self.inputs_schema = flatten(inputs, allow_non_tensor)
        self.flattened_inputs = tuple(flat)
        self.outputs_schema: Any = None

    def forward(self, *args: torch.Tensor) -> tuple[torch.Tensor, ...]:
        inputs = unflatten(list(args), self.inputs_schema)
        outputs = self.model(inputs)
        flat, self.outputs_schema = flatten(outputs, self.allow_non_tensor)
        return tuple(flat)


__all__ = ["TracingAdapter", "flatten", "unflatten"]
