"""``import rl_games...`` resolved to ``rlchain.rl_games...`` in this process (the drop-in switch).

:func:`install` puts a finder first on ``sys.meta_path``: a module name ``rl_games`` or
``rl_games.X.Y`` is answered with the module object ``rlchain.rl_games.X.Y`` (one object under both
names, so ``rl_games.common.vecenv.register`` and rlchain's registry are the same). Nothing is
written to disk and no other process sees it: the real rl_games, where installed, is untouched.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
from types import ModuleType

from rlchain.rl_games.agents import not_offered_message

ALIAS = "rl_games"
TARGET = "rlchain.rl_games"


def target_name(fullname: str) -> str | None:
    """The rlchain module that stands in for ``fullname`` (``rl_games.common`` -> ``rlchain.rl_games.common``),
    or None for a name outside rl_games."""
    if fullname == ALIAS or fullname.startswith(ALIAS + "."):
        return TARGET + fullname[len(ALIAS):]
    return None


class RlGamesAlias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """A meta-path finder and loader that answers ``rl_games.*`` with ``rlchain.rl_games.*``."""

    def find_spec(self, fullname: str, path: object = None, target: object = None
                  ) -> importlib.machinery.ModuleSpec | None:
        """A spec for an ``rl_games`` name whose rlchain module exists; for one in the table of modules rlchain
        does not offer (:data:`rlchain.rl_games.agents.NOT_OFFERED`) the one-line ImportError saying what to
        use; None for every other name (a plain ModuleNotFoundError)."""
        name = target_name(fullname)
        if name is None:
            return None
        message = not_offered_message(fullname)
        if message is not None:
            raise ImportError(message, name=fullname)
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name is not None and (exc.name == name or name.startswith(exc.name + ".")):
                return None  # rlchain has no such module
            raise  # a module of ours that failed to import: show why
        return importlib.machinery.ModuleSpec(fullname, self, origin=getattr(module, "__file__", None),
                                              is_package=hasattr(module, "__path__"))

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        """The rlchain module itself (its own ``__spec__`` is put back in :meth:`exec_module`)."""
        module = sys.modules[target_name(spec.name)]
        self._own_spec = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run: the rlchain module is already imported; keep its own spec."""
        module.__spec__ = self._own_spec


def install() -> RlGamesAlias:
    """Make ``import rl_games...`` resolve to rlchain in this process (idempotent); returns the finder.
    rl_games modules imported before are forgotten, so the names resolve to rlchain from now on."""
    for finder in sys.meta_path:
        if isinstance(finder, RlGamesAlias):
            return finder
    for name in [n for n in sys.modules if target_name(n) is not None]:
        del sys.modules[name]
    finder = RlGamesAlias()
    sys.meta_path.insert(0, finder)
    return finder


def uninstall() -> None:
    """Undo :func:`install`: remove the finder and the aliased names (the rlchain modules stay)."""
    sys.meta_path[:] = [f for f in sys.meta_path if not isinstance(f, RlGamesAlias)]
    for name in [n for n in sys.modules if target_name(n) is not None]:
        del sys.modules[name]
