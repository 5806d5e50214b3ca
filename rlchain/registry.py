"""One registry mechanism for algorithms, models, networks, environments and vecenv backends."""

from __future__ import annotations

import contextlib
import importlib
from collections.abc import Callable, Iterator
from typing import Any

from rlchain.errors import did_you_mean


def import_object(spec: str) -> Any:
    """The object a config names as ``package.module:Name`` (a callback, an event function, a mirror map); a
    one-line ValueError saying what is wrong with the name."""
    module_name, _, attr = spec.partition(":")
    if not module_name or not attr:
        raise ValueError(f"'{spec}' must look like 'package.module:Name'")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ValueError(f"cannot import '{module_name}': {exc}") from None
    if not hasattr(module, attr):
        raise ValueError(f"module '{module_name}' has no '{attr}'")
    return getattr(module, attr)


_builtins: list[Callable[[], None]] = []  # registers rlchain's own entries; run on the first lookup


def load_builtins_with(loader: Callable[[], None]) -> None:
    """``loader`` registers rlchain's built-in entries; it runs once, on the first lookup of any registry (so
    ``import rlchain`` and the ``rlchain --help`` / ``list`` commands do not import torch). Entries registered
    before it ran (a user's, a module's) win over the built-ins of the same name."""
    _builtins.append(loader)


def skip_builtins() -> None:
    """Never load rlchain's built-in entries in this process (a no-op once they are loaded): its tables are filled by
    hand. A Ray env worker registers the learner's env tables, built-ins included, and so starts without importing
    every algorithm and torch."""
    _builtins.clear()


class Deferred:
    """An entry made on its first lookup by ``make()``, then kept: a Ray env worker registers the learner's env
    entries so, and imports the modules of the one it builds only (not torch's tensor envs beside it)."""

    __slots__ = ("make",)

    def __init__(self, make: Callable[[], Any]) -> None:
        self.make = make


def ensure_builtins() -> None:
    """Run the pending built-in loader now (a no-op once it ran, and while it runs)."""
    while _builtins:
        loader = _builtins.pop(0)
        before = [(registry, dict(registry._items), set(registry._replaceable)) for registry in REGISTRIES]
        loader()
        for registry, items, replaceable in before:  # what was registered first keeps its name
            registry._items.update(items)
            registry._replaceable.difference_update(set(items) - replaceable)
            registry._replaceable.update(replaceable)


class RegistryError(KeyError):
    """Raised when a name is looked up that nobody registered."""

    def __str__(self) -> str:  # KeyError quotes its message; we want it plain
        return str(self.args[0])


class Registry:
    """A named table of builders: ``register(name, obj)`` then ``get(name)``.

    Every extension point of rlchain (algos, models, networks, envs, vecenv backends) is an
    instance of this class, so user code extends all of them the same way.
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._items: dict[str, Any] = {}
        self._replaceable: set[str] = set()

    def register(self, name: str, obj: Any = None, *, overwrite: bool = False, replaceable: bool = False) -> Any:
        """Register ``obj`` under ``name``; usable as a decorator when ``obj`` is omitted.

        ``replaceable`` marks a built-in example (e.g. the ``testnet`` networks) that user code may
        register its own ``name`` over without ``overwrite=True``, as rl_games users do.
        """
        if obj is None:
            def decorator(target: Any) -> Any:
                self.register(name, target, overwrite=overwrite, replaceable=replaceable)
                return target
            return decorator
        taken = name in self._items and self._items[name] is not obj and name not in self._replaceable
        if taken and not overwrite:
            raise ValueError(f"{self.kind} '{name}' is already registered; pass overwrite=True to replace it")
        self._items[name] = obj
        if replaceable:
            self._replaceable.add(name)
        else:
            self._replaceable.discard(name)
        return obj

    def unregister(self, name: str) -> None:
        """Remove ``name``; a name nobody registered raises RegistryError with a did-you-mean."""
        ensure_builtins()
        if name not in self._items:
            raise RegistryError(self.unknown_message(name))
        del self._items[name]
        self._replaceable.discard(name)

    @contextlib.contextmanager
    def scoped(self) -> Iterator[Registry]:
        """Registrations made inside the ``with`` block are undone when it ends (a test's own names).

        What was registered before is back as it was, replaced or unregistered names included, also
        when the block raises; the table object is the same one throughout.
        """
        ensure_builtins()
        items, replaceable = dict(self._items), set(self._replaceable)
        try:
            yield self
        finally:
            self._items.clear()
            self._items.update(items)
            self._replaceable.clear()
            self._replaceable.update(replaceable)

    def get(self, name: str) -> Any:
        """Return what was registered under ``name`` or raise with a did-you-mean."""
        ensure_builtins()
        try:
            value = self._items[name]
        except KeyError:
            raise RegistryError(self.unknown_message(name)) from None
        if isinstance(value, Deferred):
            value = self._items[name] = value.make()
        return value

    def unknown_message(self, name: str) -> str:
        """A one-line explanation of a failed lookup, with the closest registered names."""
        ensure_builtins()
        hint = did_you_mean(name, self._items)
        known = ", ".join(sorted(self._items))
        return f"unknown {self.kind} '{name}'{hint} (registered: {known})"

    def __getitem__(self, name: str) -> Any:  # rl_games reads its tables as dicts: configurations[name]
        return self.get(name)

    def __contains__(self, name: object) -> bool:
        ensure_builtins()
        return name in self._items

    def __iter__(self) -> Iterator[str]:
        ensure_builtins()
        return iter(sorted(self._items))

    def names(self) -> list[str]:
        """Every registered name, sorted."""
        ensure_builtins()
        return sorted(self._items)


ALGOS = Registry("algo")
MODELS = Registry("model")
NETWORKS = Registry("network")
ENVS = Registry("env")
"""``params.config.env_name`` name -> its entry, the dict given to ``rlchain.env_configurations.register``
(``env_creator`` / ``vecenv_creator`` / ``vecenv_type``); rl_games' ``env_configurations.configurations``."""
VECENVS = Registry("vecenv_type")
"""``params.config.vecenv_type`` name -> rl_games-style creator ``(config_name, num_actors, **env_config)``."""
WRITERS = Registry("log writer")
"""``params.config.log_writers`` name -> writer class ``(run_dir) -> Writer`` (rlchain/runs/writers.py)."""

NETWORK_CONFIGS: dict[str, type] = {}
"""network name -> the dataclass its block parses into, given to ``register_network(config_class=...)``."""

REGISTRIES = (ALGOS, MODELS, NETWORKS, ENVS, VECENVS, WRITERS)


@contextlib.contextmanager
def scoped_registrations() -> Iterator[None]:
    """Every registry and ``NETWORK_CONFIGS`` as they were once the block ends.

    For tests (rlchain's and a user's) that register their own envs, networks or writers.
    """
    ensure_builtins()
    saved = dict(NETWORK_CONFIGS)
    with contextlib.ExitStack() as stack:
        for registry in REGISTRIES:
            stack.enter_context(registry.scoped())
        try:
            yield
        finally:
            NETWORK_CONFIGS.clear()
            NETWORK_CONFIGS.update(saved)


def network_config_class(name: str) -> type | None:
    """The dataclass a network block named ``name`` parses into: the one given at registration, else the
    builder's ``config_class`` attribute; None: the block stays a dict."""
    ensure_builtins()
    if name in NETWORK_CONFIGS:
        return NETWORK_CONFIGS[name]
    return getattr(NETWORKS.get(name), "config_class", None) if name in NETWORKS else None
