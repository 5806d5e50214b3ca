"""``python -m rlchain.rllib SCRIPT [ARGS...]``: run an RLlib script unchanged on rlchain.

The script runs as ``python SCRIPT ARGS`` would (``sys.argv``, ``__main__``, its folder first on ``sys.path``)
with ``import ray.rllib...`` resolving to :mod:`rlchain.rllib` (:mod:`.alias`); ``ray``, ``ray.tune`` and
``ray.init`` stay the real Ray. A name the face does not offer ends the run with one line saying what to use
instead (exit code 1).
"""

from __future__ import annotations

import os
import runpy
import sys

from rlchain.config.errors import ConfigError
from rlchain.rllib.alias import FaceImportError, install
from rlchain.runs.checkpoint import CheckpointError
from rlchain.version import __version__

USAGE = "usage: python -m rlchain.rllib SCRIPT [ARGS...]  (runs SCRIPT with rlchain standing in for RLlib)"


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(USAGE, file=sys.stderr if not argv else sys.stdout)
        return 2 if not argv else 0
    script = argv[0]
    if not os.path.isfile(script):
        print(f"python -m rlchain.rllib: {script}: no such script file ({USAGE})", file=sys.stderr)
        return 2
    print(f"rlchain {__version__} stands in for RLlib: running {script} with 'import ray.rllib' resolved to "
          f"rlchain.rllib", flush=True)
    install()
    sys.argv = [script, *argv[1:]]
    sys.path[0] = os.path.dirname(os.path.abspath(script))
    try:
        runpy.run_path(script, run_name="__main__")
    except FaceImportError as exc:
        print(f"{script}: ImportError: {exc}", file=sys.stderr)
        return 1
    except (ConfigError, CheckpointError) as exc:  # already one line naming the key / file
        print(f"{script}: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    except ImportError as exc:
        if exc.name and exc.name.startswith(("ray.rllib", "rlchain.rllib")):
            print(f"{script}: ImportError: {exc} (not offered by rlchain's RLlib face; see docs/rllib.md)",
                  file=sys.stderr)
            return 1
        raise
    return 0


if __name__ == "__main__":
    sys.exit(main())
