"""``python -m rlchain.rllib SCRIPT [ARGS...]``: run an RLlib script unchanged on rlchain.

The script runs as ``python SCRIPT ARGS`` would (``sys.argv``, ``__main__``, its folder first on ``sys.path``)
with ``import ray.rllib...`` resolving to :mod:`rlchain.rllib` (:mod:`.alias`); ``ray``, ``ray.tune`` and
``ray.init`` stay the real Ray. A name the face does not offer ends the run with one line saying what to use
instead (exit code 1).
"""

from __future__ import annotations

import os
import re
import sys

from rlchain.config.errors import ConfigError
from rlchain.faces import run_script
from rlchain.rllib.alias import FaceImportError, RLlibAlias, missing_name_instead
from rlchain.rllib.face_error import FaceNotOffered
from rlchain.runs.checkpoint import CheckpointError

_FACE_DIR = os.path.dirname(os.path.abspath(__file__)) + os.sep
"""The face's own folder: its ``examples`` helpers are not RLlib's example modules."""

_CANNOT_IMPORT = re.compile(r"cannot import name '([^']+)' from '((?:ray|rlchain)\.rllib[\w.]*)'")
"""Python's message for ``from <module> import <name>`` where the module has no such name."""


def _missing_name(exc: ImportError) -> str | None:
    """The line for ``from ray.rllib.X import Y`` where the face's X has no Y, in the script's own names."""
    match = _CANNOT_IMPORT.match(str(exc))
    if match is None:
        return None
    name, module = match.groups()
    module = "ray" + module.removeprefix("rlchain") if module.startswith("rlchain.") else module
    return f"ImportError: {module} has no {name} under rlchain's RLlib face: {missing_name_instead(module, name)}"


def example_importer(exc: BaseException) -> str | None:
    """The RLlib example module (``ray.rllib.examples...``, read from the installed RLlib) whose own import raised
    ``exc``, the innermost one in its traceback, in RLlib's names; None when the script imported it itself."""
    found, tb = None, exc.__traceback__
    while tb is not None:
        name = tb.tb_frame.f_globals.get("__name__", "")
        theirs = not tb.tb_frame.f_code.co_filename.startswith(_FACE_DIR)  # not the face's examples.utils
        if theirs and name.startswith(("rlchain.rllib.examples.", "ray.rllib.examples.")):
            found = "ray" + name.removeprefix("rlchain") if name.startswith("rlchain.") else name
        tb = tb.tb_next
    return found


def explain(exc: Exception) -> str | None:
    """The one line an error of the face ends the script with, or None for any other exception."""
    if isinstance(exc, FaceImportError):
        importer = example_importer(exc)
        by = f" (imported by RLlib's example module {importer})" if importer else ""
        return f"ImportError: {exc}{by}"
    if isinstance(exc, (ConfigError, CheckpointError, FaceNotOffered)):  # already one line naming the key / file
        return f"{type(exc).__name__}: {exc}"
    if not isinstance(exc, ImportError):
        return None
    line = _missing_name(exc)
    if line is None and exc.name and exc.name.startswith(("ray.rllib", "rlchain.rllib")):
        line = f"ImportError: {exc} (not offered by rlchain's RLlib face; see docs/rllib.md)"
    return line


def main(argv: list[str] | None = None) -> int:
    """Run the script named by ``argv[0]`` (:func:`rlchain.faces.run_script`)."""
    return run_script(argv, "rlchain.rllib", "RLlib", RLlibAlias, explain)


if __name__ == "__main__":
    sys.exit(main())
