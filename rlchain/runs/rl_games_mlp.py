"""Where an rl_games MLP's modules sit in rlchain's: one rl_games Sequential against rlchain's blocks.

rl_games builds an MLP as one Sequential: per hidden layer linear, activation and, with
``network.normalization``, a norm module after the activation (rl_games 2.0; 1.6.5 builds none). rlchain's
:class:`~rlchain.networks.mlp.MLP` holds one Sequential block per layer, ``net.<layer>.<position>``: the linear
layer at 0 and, with ``mlp.norm_after_activation``, the norm at 2 (at 1, before the activation, without it:
a function rl_games does not compute). Activations hold no tensors, so only linear and norm modules are seen.
"""

from __future__ import annotations

import re
from typing import Any

NORM_BEFORE_ACTIVATION = ("is a normalization layer before the activation (rlchain's default order): rl_games "
                          "normalizes after it, so rl_games cannot compute this network (train with "
                          "network.mlp.norm_after_activation: True)")


def sequential_layers(tensors: dict[str, Any], seq: str, label: str) -> dict[int, tuple[int, int]]:
    """rl_games' ``<seq>.<index>`` -> (layer, position in rlchain's block) for every module of that Sequential in
    ``tensors`` that holds tensors. ``label`` prefixes key names in errors."""
    weights: dict[int, int] = {}
    for key, value in tensors.items():
        match = re.fullmatch(rf"{re.escape(seq)}\.(\d+)\.(\w+)", key)
        if match is None:
            if key.startswith(seq + "."):
                raise ValueError(f"'{label}{key}' is not a linear or norm layer of rl_games' MLP")
            continue
        if match.group(2) == "weight":
            weights[int(match.group(1))] = len(getattr(value, "shape", ()))
    out: dict[int, tuple[int, int]] = {}
    layer, expected, norm_at = -1, 0, None
    for index in sorted(weights):
        if weights[index] == 2 and index == expected:  # a linear layer opens the next block
            layer += 1
            out[index] = (layer, 0)
            expected, norm_at = index + 2, index + 2
        elif weights[index] == 1 and index == norm_at:  # a norm after this block's activation
            out[index] = (layer, 2)
            expected, norm_at = index + 1, None
        else:
            raise ValueError(f"'{label}{seq}.{index}.weight' is not where rl_games' MLP puts a linear or norm "
                             f"layer (rlchain reads MLPs without D2RL)")
    for key in tensors:
        match = re.fullmatch(rf"{re.escape(seq)}\.(\d+)\.\w+", key)
        if match is not None and int(match.group(1)) not in out:
            raise ValueError(f"'{label}{key}' is not a linear or norm layer of rl_games' MLP")
    return out


def block_indices(keys: list[str], prefix: str, label: str = "") -> tuple[dict[tuple[int, int], int], int]:
    """For rlchain keys ``<prefix><layer>.<position>.<p>`` of one MLP: (layer, position) -> rl_games' Sequential
    index, and the index after the last block (where rl_games puts an output layer in the same Sequential). A
    norm before the activation (position 1) is a ValueError."""
    blocks: dict[int, set[int]] = {}
    for key in keys:
        match = re.fullmatch(rf"{re.escape(prefix)}(\d+)\.(\d+)\.\w+", key)
        if match is None:
            continue
        layer, position = int(match.group(1)), int(match.group(2))
        if position == 1:
            raise ValueError(f"'{label}{key}' {NORM_BEFORE_ACTIVATION}")
        blocks.setdefault(layer, set()).add(position)
    out: dict[tuple[int, int], int] = {}
    index = 0
    for layer in sorted(blocks):
        out[(layer, 0)] = index
        if 2 in blocks[layer]:
            out[(layer, 2)] = index + 2
        index += 3 if 2 in blocks[layer] else 2
    return out, index


__all__ = ["NORM_BEFORE_ACTIVATION", "block_indices", "sequential_layers"]
