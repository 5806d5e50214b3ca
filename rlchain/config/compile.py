"""``config.torch_compile``: the rl_games-style setting, parsed into a :class:`CompileSpec` (no torch here)."""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.fields import option, parse_value

MODES = ("default", "reduce-overhead", "max-autotune", "max-autotune-no-cudagraphs")
BACKENDS = ("inductor", "eager", "aot_eager", "cudagraphs")


@dataclass(frozen=True)
class CompileSpec:
    """What to compile with: the actor-critic's mode, the central value network's mode, the backend."""

    mode: str = option("default", "torch.compile mode of the actor-critic", choices=MODES)
    critic_mode: str | None = option(None, "mode of the central value network (default: mode)", choices=MODES)
    backend: str = option("inductor", "torch.compile backend", choices=BACKENDS)

    def __post_init__(self) -> None:
        if self.critic_mode is None:  # set once, while the frozen value is built
            object.__setattr__(self, "critic_mode", self.mode)


def parse_compile(value: Any) -> CompileSpec | None:
    """False/None -> off; True -> default mode; 'mode'; or {mode, critic_mode, backend} (a CompileSpec passes
    through). The keys and their choices are CompileSpec's fields, checked by the schema's ``parse_value``.

    Raises ValueError with the expected forms for anything else.
    """
    if value is None or value is False or isinstance(value, CompileSpec):
        return value or None
    if value is True:
        return CompileSpec()
    if isinstance(value, str):
        if value.lower() in ("false", "none", "off"):
            return None
        if value.lower() in ("true", "on"):
            return CompileSpec()
        return CompileSpec(mode=_field(value, "mode"), critic_mode=value)
    if isinstance(value, dict):
        names = [f.name for f in dataclasses.fields(CompileSpec)]
        unknown = sorted(set(value) - set(names))
        if unknown:
            raise ValueError(f"unknown key '{unknown[0]}' (known: {', '.join(names)})")
        return CompileSpec(**{name: _field(value[name], name) for name in names if name in value})
    raise ValueError(f"expected false, true, a mode ({', '.join(MODES)}) or {{mode, critic_mode, backend}}, "
                     f"got {value!r}")


def _field(value: Any, name: str) -> Any:
    """One CompileSpec key through the schema's parse_value (type and choices); ValueError naming the key."""
    field = next(f for f in dataclasses.fields(CompileSpec) if f.name == name)
    try:
        return parse_value(typing.get_type_hints(CompileSpec)[name], value, name, "", field.metadata)
    except ConfigError as exc:
        raise ValueError(f"{name} {exc.message}") from None


def check_compile(value: Any) -> str | None:
    """The schema's check: an error string, or None when ``value`` parses."""
    try:
        parse_compile(value)
    except ValueError as exc:
        return str(exc)
    return None


def check_cuda_graph(value: Any) -> str | None:
    """The schema's check: True, False or auto."""
    return None if value is True or value is False or value == "auto" else \
        f"expected True, False or auto, got {value!r}"
