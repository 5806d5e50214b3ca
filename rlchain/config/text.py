"""Reading a YAML or JSON file into plain values, safely: UTF-8 only, aliases refused (they expand beyond
memory), nesting bounded before the parsers recurse, syntax errors as ``line L, column C`` with the line."""

from __future__ import annotations

import json
from typing import Any

import yaml

from rlchain.config.errors import ConfigError


def syntax_error(exc: Exception, text: str) -> str:
    """A YAML / JSON syntax error as ``line L, column C: problem``, then the offending line and a caret under
    the column (the parser's own message, flattened, when it gives no position)."""
    if isinstance(exc, json.JSONDecodeError):
        line, column, problem = exc.lineno, exc.colno, exc.msg
    else:
        mark = getattr(exc, "problem_mark", None)
        if mark is None:
            return " ".join(str(exc).split())
        line, column = mark.line + 1, mark.column + 1
        context = getattr(exc, "context", None)
        problem = f"{getattr(exc, 'problem', None) or 'syntax error'}" + (f" ({context})" if context else "")
    lines = text.splitlines()
    where = f"line {line}, column {column}: {problem}"
    if line > len(lines):
        return f"{where} (at the end of the file)"
    shown = lines[line - 1] if line > 0 else ""
    if not shown.strip():
        return where  # a blank line and a caret under it would say nothing more
    return f"{where}\n    {shown}\n    {' ' * (column - 1)}^"


class NoAliasLoader(yaml.SafeLoader):
    """YAML without aliases (``*name``): a config has no need for them, and nested aliases expand
    exponentially (a few lines can describe more data than memory holds)."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise AliasFound(f"line {event.start_mark.line + 1}: YAML alias *{event.anchor} is not allowed in a "
                              f"config (write the value out, or use a key.path=value override)")
        return super().compose_node(parent, index)


class AliasFound(Exception):
    pass


def read_data(path: str) -> Any:
    """The value of a YAML or JSON file; text that is not UTF-8, nests too deeply, holds aliases or does not
    parse is a one-line ConfigError naming the file."""
    with open(path, "rb") as fh:
        blob = fh.read()
    try:
        text = blob.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(path, "", f"not UTF-8 text (byte 0x{blob[exc.start]:02x} at offset {exc.start}); a "
                                    f"config is a YAML or JSON text file") from None
    depth = nesting(text)
    if depth > 4 * MAX_NESTING:  # before parsing, which recurses per level (brackets in strings count: a margin)
        raise ConfigError(path, "", f"nested {depth} levels deep (brackets or braces); a config nests at most "
                                    f"{MAX_NESTING}")
    try:
        data = json.loads(text) if path.endswith(".json") else yaml.load(text, Loader=NoAliasLoader)  # noqa: S506
    except AliasFound as exc:
        raise ConfigError(path, "", str(exc)) from None
    except (json.JSONDecodeError, yaml.YAMLError) as exc:
        raise ConfigError(path, "", f"cannot parse file: {syntax_error(exc, text)}", lines=True) from None
    except RecursionError:  # nesting by indentation, which the bracket count does not see
        raise ConfigError(path, "", f"nested too deeply; a config nests at most {MAX_NESTING} levels") from None
    if depth_of(data) > MAX_NESTING:
        raise ConfigError(path, "", f"nested more than {MAX_NESTING} levels deep; a config nests at most "
                                    f"{MAX_NESTING}")
    return data


MAX_NESTING = 64
"""Levels of lists and mappings a config may nest (rlchain's deepest block nests about 8)."""


def nesting(text: str) -> int:
    """The deepest run of unclosed ``[`` / ``{`` in ``text`` (quotes not parsed: an over-estimate at worst
    only for configs holding thousands of brackets inside strings)."""
    depth = deepest = 0
    for char in text:
        if char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}" and depth:
            depth -= 1
    return deepest


def depth_of(value: Any) -> int:
    """How many lists / mappings deep ``value`` nests, counted without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        node, level = stack.pop()
        if isinstance(node, (dict, list)):
            if level > MAX_NESTING:
                return level
            deepest = max(deepest, level)
            stack.extend((child, level + 1) for child in (node.values() if isinstance(node, dict) else node))
    return deepest
