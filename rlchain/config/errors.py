"""The one exception type for bad configuration, always a single readable line, and the
did-you-mean hint that such lines carry."""

import difflib
from typing import Any


class ConfigError(ValueError):
    """A config problem: names the file, the key path and what was expected."""

    def __init__(self, source: str, path: str, message: str, lines: bool = False) -> None:
        self.source = source
        self.path = path
        self.message = message
        where = f"{source}: " if source else ""
        key = f"{path}: " if path else ""
        super().__init__(one_line(f"{where}{key}{message}", keep_breaks=lines))


def one_line(text: str, keep_breaks: bool = False) -> str:
    """``text`` with line breaks and other control characters written as escapes (a value quoted from the
    config may hold any), so an error stays one line; ``keep_breaks``: a message made of lines on purpose
    (a syntax error's quoted line and caret)."""
    return "".join(c if c.isprintable() or (keep_breaks and c == "\n") else c.encode("unicode_escape").decode("ascii")
                   for c in text)


def did_you_mean(name: str, candidates: Any) -> str:
    """'; did you mean 'X', 'Y'?' for the closest candidates (case-insensitive), or ''."""
    by_lower = {str(c).lower(): str(c) for c in candidates}
    close = difflib.get_close_matches(str(name).lower(), list(by_lower), n=3, cutoff=0.6)
    return f"; did you mean {', '.join(repr(by_lower[c]) for c in close)}?" if close else ""
