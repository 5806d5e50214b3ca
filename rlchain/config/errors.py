"""The one exception type for bad configuration, always a single readable line (its did-you-mean hint:
:func:`rlchain.errors.did_you_mean`)."""



class ConfigError(ValueError):
    """A config problem: names the file, the key path and what was expected."""

    def __init__(self, source: str, path: str, message: str) -> None:
        self.source = source
        self.path = path
        self.message = message
        where = f"{source}: " if source else ""
        key = f"{path}: " if path else ""
        super().__init__(f"{where}{key}{message}")

