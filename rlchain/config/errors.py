"""The one exception type for bad configuration, always a single readable line (its did-you-mean hint:
:func:`rlchain.errors.did_you_mean`)."""



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

