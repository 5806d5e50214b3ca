"""Whether a value is a torch tensor, without importing torch.

The env layer (the VecEnv contract, the backends, the wrappers) imports torch only where a tensor env or the
trainer needs it, so a process that only steps numpy envs (a Ray env worker) starts without torch's few
seconds of imports. A process that never imported torch holds no tensor, so looking torch up in
``sys.modules`` answers the question exactly.
"""

from __future__ import annotations

import sys
from typing import Any


def is_tensor(value: Any) -> bool:
    """``isinstance(value, torch.Tensor)``, False at no cost where torch was never imported."""
    torch = sys.modules.get("torch")
    return torch is not None and isinstance(value, torch.Tensor)


__all__ = ["is_tensor"]
