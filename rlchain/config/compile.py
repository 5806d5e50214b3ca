"""``config.torch_compile``: the rl_games-style setting, parsed into a :class:`CompileSpec` (no torch here)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

MODES = ("default", "reduce-overhead", "max-autotune", "max-autotune-no-cudagraphs")
BACKENDS = ("inductor", "eager", "aot_eager", "cudagraphs")


@dataclass(frozen=True)
class CompileSpec:
    """What to compile with: the actor-critic's mode, the central value network's mode, the backend."""

    mode: str = "default"
    critic_mode: str = "default"
    backend: str = "inductor"


def parse_compile(value: Any) -> CompileSpec | None:
    """False/None -> off; True -> default mode; 'mode'; or {mode, critic_mode, backend}.

    Raises ValueError with the expected forms for anything else.
    """
    if value is None or value is False:
        return None
    if value is True:
        return CompileSpec()
    if isinstance(value, str):
        if value.lower() in ("false", "none", "off"):
            return None
        if value.lower() in ("true", "on"):
            return CompileSpec()
        _check(value, MODES, "mode")
        return CompileSpec(mode=value, critic_mode=value)
    if isinstance(value, dict):
        unknown = set(value) - {"mode", "critic_mode", "backend"}
        if unknown:
            raise ValueError(f"unknown key '{sorted(unknown)[0]}' (known: mode, critic_mode, backend)")
        mode = str(value.get("mode", "default"))
        spec = CompileSpec(mode, str(value.get("critic_mode", mode)), str(value.get("backend", "inductor")))
        _check(spec.mode, MODES, "mode")
        _check(spec.critic_mode, MODES, "critic_mode")
        _check(spec.backend, BACKENDS, "backend")
        return spec
    raise ValueError(f"expected false, true, a mode ({', '.join(MODES)}) or {{mode, critic_mode, backend}}, "
                     f"got {value!r}")


def check_compile(value: Any) -> str | None:
    """The schema's check: an error string, or None when ``value`` parses."""
    try:
        parse_compile(value)
    except ValueError as exc:
        return str(exc)
    return None


def _check(value: str, allowed: tuple[str, ...], what: str) -> None:
    if value not in allowed:
        raise ValueError(f"{what} '{value}' is not one of: {', '.join(allowed)}")
