"""A small typed-dataclass parser: dict -> dataclass with type checks, choices and did-you-mean.

Schema dataclasses declare fields with :func:`option`, which records the documentation, the
allowed choices and the implementation status used by ``docs/config.md``.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from typing import Any, Union

from rlchain.config.errors import ConfigError
from rlchain.errors import closest, did_you_mean

NONE_STRINGS = {"none", "null", "~"}


def option(default: Any = dataclasses.MISSING, doc: str = "", *, choices: tuple | None = None,
           status: str = "yes", check: typing.Callable[[Any], str | None] | None = None,
           empty_is_present: bool = False) -> Any:
    """Declare a config field: default, one-line meaning, allowed choices and status.

    ``status`` is ``yes`` (implemented), ``deprecated`` (accepted, no effect) or a note for
    keys that are accepted only at their default (e.g. ``planned``).
    ``check`` returns an error string for an impossible value, or None.
    ``empty_is_present``: for an optional block, an empty value (``discrete:``) means the block with
    its defaults; otherwise an empty or ``None`` value means no block (``rnn: None``).
    """
    meta = {"doc": doc, "choices": choices, "status": status, "check": check,
            "empty_is_present": empty_is_present}
    if isinstance(default, (list, dict)) or dataclasses.is_dataclass(default):
        value = default
        return dataclasses.field(default_factory=lambda: _copy(value), metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def variant(base: type, name: str, **changes: Any) -> Any:
    """Field ``name`` of the dataclass ``base``, declared again on another config class: a subclass that gives
    it another ``default`` or ``doc``/``status`` (e.g. a key an algorithm accepts but does not implement), or a
    sibling algorithm that reads the same key (appo and PPO's ``e_clip``): the type, choices and check stay
    the ones declared once in ``base``."""
    f = {g.name: g for g in dataclasses.fields(base)}[name]
    meta = {**f.metadata, **{k: v for k, v in changes.items() if k != "default"}}
    if "default" in changes:
        default = changes["default"]
    else:
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
    return option(default, meta["doc"], choices=meta["choices"], status=meta["status"], check=meta["check"],
                  empty_is_present=meta["empty_is_present"])


def _copy(value: Any) -> Any:
    import copy
    return copy.deepcopy(value)


def parse_dataclass(cls: type, data: Any, path: str, source: str) -> Any:
    """Build ``cls`` from ``data`` (a dict), checking every key and value."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(source, path, f"expected a mapping of keys, got {type(data).__name__} {data!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = [k for k in data if k not in fields]
    if unknown:
        key = unknown[0]
        hint = did_you_mean(key, fields, n=1) or f"; known keys: {', '.join(sorted(fields))}"
        raise ConfigError(source, _join(path, key), f"unknown key{hint}")
    kwargs = {}
    for name, f in fields.items():
        if name not in data:
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise ConfigError(source, _join(path, name), "required key is missing")
            continue
        kwargs[name] = parse_value(hints[name], data[name], _join(path, name), source, f.metadata)
    return cls(**kwargs)


def parse_value(tp: Any, value: Any, path: str, source: str, meta: typing.Mapping | None = None) -> Any:
    """Convert one YAML value to type ``tp`` or raise a ConfigError naming ``path``."""
    meta = meta or {}
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (Union, types.UnionType):
        non_none = [a for a in args if a is not type(None)]
        if _is_none(value):
            if dataclasses.is_dataclass(non_none[0]) and meta.get("empty_is_present"):
                return parse_dataclass(non_none[0], {}, path, source)  # `discrete:` with no body
            return None
        out = parse_value(non_none[0], value, path, source, meta)
    elif dataclasses.is_dataclass(tp):
        out = parse_dataclass(tp, value, path, source)
    elif origin is list:
        if not isinstance(value, (list, tuple)):
            raise ConfigError(source, path, f"expected a list, got {value!r}")
        out = [parse_value(args[0], v, f"{path}[{i}]", source) for i, v in enumerate(value)]
    elif origin is dict or tp is dict:
        if _is_none(value):
            return {}
        if not isinstance(value, dict):
            raise ConfigError(source, path, f"expected a mapping, got {value!r}")
        out = dict(value)
    elif tp is bool:
        out = _to_bool(value, path, source)
    elif tp is int:
        out = _to_int(value, path, source)
    elif tp is float:
        out = _to_float(value, path, source)
    elif tp is str:
        if isinstance(value, (dict, list)):
            raise ConfigError(source, path, f"expected a string, got {value!r}")
        if value is None:  # str(None) would be the folder / name 'None'
            raise ConfigError(source, path, "expected a string, got null (leave the key out for its default)")
        out = str(value)
    elif tp is Any:
        out = value
    else:  # pragma: no cover - schema bug
        raise TypeError(f"unsupported schema type {tp} at {path}")
    choices = meta.get("choices")
    if choices is not None and out is not None and out not in choices:
        close = closest(out, choices, n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        shown = ", ".join("None" if c is None else str(c) for c in choices)
        raise ConfigError(source, path, f"'{out}' is not one of: {shown}{hint}")
    check = meta.get("check")
    if check is not None and out is not None:
        problem = check(out)
        if problem:
            raise ConfigError(source, path, f"{problem}, got {out!r}")
    return out


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else str(key)


def _is_none(value: Any) -> bool:
    return value is None or (isinstance(value, str) and value.strip().lower() in NONE_STRINGS)


def _to_bool(value: Any, path: str, source: str) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, str) and value.strip().lower() in ("true", "yes", "on", "false", "no", "off"):
        return value.strip().lower() in ("true", "yes", "on")
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    raise ConfigError(source, path, f"expected true or false, got {value!r}")


def _to_int(value: Any, path: str, source: str) -> int:
    if isinstance(value, bool):
        raise ConfigError(source, path, f"expected an integer, got {value!r}")
    if isinstance(value, int):
        return value
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(source, path, f"expected an integer, got {value!r}") from None
    if not number.is_integer():
        raise ConfigError(source, path, f"expected an integer, got {value!r}")
    if abs(number) > 2**53:  # past a float's exact integers: 1.0e+308 is no size anyone meant
        raise ConfigError(source, path, f"expected an integer, got the float {value!r} (write an integer)")
    return int(number)


def _to_float(value: Any, path: str, source: str) -> float:
    """Numbers and numeric strings: YAML 1.1 reads ``2e-4`` as a string, rl_games accepts it."""
    if isinstance(value, bool):
        raise ConfigError(source, path, f"expected a number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(source, path, f"expected a number, got {value!r}") from None
    if math.isnan(number):
        raise ConfigError(source, path, "expected a number, got NaN")
    return number


def positive(x: Any) -> str | None:
    return None if x > 0 else "must be > 0"


def non_negative(x: Any) -> str | None:
    return None if x >= 0 else "must be >= 0"


def above_one(x: Any) -> str | None:
    return None if x > 1 else "must be > 1"


def check_env_groups(x: Any) -> str | None:
    """``env_groups``: ``auto`` or an int >= 1."""
    if x == "auto" or (isinstance(x, int) and not isinstance(x, bool) and x >= 1):
        return None
    return "must be auto or an integer >= 1"


def unit_interval(x: Any) -> str | None:
    return None if 0 <= x <= 1 else "must be between 0 and 1"


def rate_target(x: Any) -> str | None:
    """A success-rate target: a fraction, or inf (off)."""
    return None if 0 <= x <= 1 or x == float("inf") else "must be between 0 and 1 (a fraction of episodes), or inf"
