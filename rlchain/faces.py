"""What the compatibility faces (``rlchain.rl_games``, ``rlchain.rllib``) share: the import alias that makes a
peer's module names resolve to the face in this process, and ``python -m rlchain.<face> SCRIPT`` that runs a
peer's script unchanged with that alias installed.

:class:`ModuleAlias` is put first on ``sys.meta_path``: a name ``<alias>`` or ``<alias>.X.Y`` is answered with the
module object ``<target>.X.Y`` (one object under both names). Nothing is written to disk and no other process
sees it: the peer's own package, where installed, is untouched.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import os
import runpy
import sys
from collections.abc import Callable
from types import ModuleType

from rlchain.version import __version__


class ModuleAlias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """A meta-path finder and loader answering ``ALIAS.*`` with ``TARGET.*``; a face subclasses it, naming both."""

    ALIAS = ""
    TARGET = ""

    @classmethod
    def target_name(cls, fullname: str) -> str | None:
        """The face's module that stands in for ``fullname`` (``rl_games.common`` -> ``rlchain.rl_games.common``),
        or None for a name outside the alias."""
        if fullname == cls.ALIAS or fullname.startswith(cls.ALIAS + "."):
            return cls.TARGET + fullname[len(cls.ALIAS):]
        return None

    def refuse(self, fullname: str) -> None:
        """Raise the face's one-line ImportError for a name it does not offer, before anything is imported."""

    def missing(self, fullname: str) -> None:
        """Called for an aliased name the face has no module for; returns for a plain ModuleNotFoundError."""

    def find_spec(self, fullname: str, path: object = None, target: object = None
                  ) -> importlib.machinery.ModuleSpec | None:
        """A spec for an aliased name whose face module exists; None for every other name."""
        name = self.target_name(fullname)
        if name is None:
            return None
        self.refuse(fullname)
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name is not None and (exc.name == name or name.startswith(exc.name + ".")):
                self.missing(fullname)
                return None  # the face has no such module
            raise  # a module of the face that failed to import: show why
        return importlib.machinery.ModuleSpec(fullname, self, origin=getattr(module, "__file__", None),
                                              is_package=hasattr(module, "__path__"))

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        """The face's module itself (its own ``__spec__`` is put back in :meth:`exec_module`)."""
        module = sys.modules[self.target_name(spec.name)]
        self._own_spec = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run: the face's module is already imported; keep its own spec."""
        module.__spec__ = self._own_spec

    @classmethod
    def _forget(cls) -> None:
        for name in [n for n in sys.modules if cls.target_name(n) is not None]:
            del sys.modules[name]

    @classmethod
    def install(cls) -> ModuleAlias:
        """Make the aliased names resolve to the face in this process (idempotent); returns the finder. Modules
        imported under those names before are forgotten, so the names resolve to the face from now on."""
        for finder in sys.meta_path:
            if isinstance(finder, cls):
                return finder
        cls._forget()
        finder = cls()
        sys.meta_path.insert(0, finder)
        return finder

    @classmethod
    def uninstall(cls) -> None:
        """Undo :meth:`install`: remove the finder, the aliased names and the parent package's attribute that
        points at the face (``ray.rllib``); the face's modules stay."""
        sys.meta_path[:] = [f for f in sys.meta_path if not isinstance(f, cls)]
        cls._forget()
        parent, _, child = cls.ALIAS.rpartition(".")
        module = sys.modules.get(parent) if parent else None
        if getattr(getattr(module, child, None), "__name__", None) == cls.TARGET:
            delattr(module, child)


def run_script(argv: list[str] | None, face: str, peer: str, alias: type[ModuleAlias],
               explain: Callable[[Exception], str | None] = lambda exc: None) -> int:
    """``python -m <face> SCRIPT [ARGS...]``: run SCRIPT as ``python SCRIPT ARGS`` would (``sys.argv`` is
    ``[SCRIPT, *ARGS]``, it runs as ``__main__``, its folder is first on ``sys.path``) with ``alias`` installed.

    Returns 2 on a bad launch line (0 for ``--help``); the script's own ``sys.exit`` ends the process as under
    plain ``python``. ``explain``: the one line an exception of the script ends the run with (exit code 1), or
    None to let it through."""
    argv = list(sys.argv[1:] if argv is None else argv)
    usage = f"usage: python -m {face} SCRIPT [ARGS...]  (runs SCRIPT with rlchain standing in for {peer})"
    if not argv or argv[0] in ("-h", "--help"):
        print(usage, file=sys.stderr if not argv else sys.stdout)
        return 2 if not argv else 0
    script = argv[0]
    if not os.path.isfile(script):
        print(f"python -m {face}: {script}: no such script file ({usage})", file=sys.stderr)
        return 2
    print(f"rlchain {__version__} stands in for {peer}: running {script} with 'import {alias.ALIAS}' resolved "
          f"to {alias.TARGET}", flush=True)
    alias.install()
    sys.argv = [script, *argv[1:]]
    sys.path[0] = os.path.dirname(os.path.abspath(script))  # as `python SCRIPT` sets it
    try:
        runpy.run_path(script, run_name="__main__")
    except Exception as exc:
        line = explain(exc)
        if line is None:
            raise
        print(f"{script}: {line}", file=sys.stderr)
        return 1
    return 0
