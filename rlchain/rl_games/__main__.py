"""``python -m rlchain.rl_games SCRIPT [ARGS...]``: run an rl_games script unchanged on rlchain.

The script runs as ``python SCRIPT ARGS`` would run it (``sys.argv`` is ``[SCRIPT, *ARGS]``, it runs as
``__main__``, its folder is first on ``sys.path``, its exit code is the process's), with
``import rl_games...`` resolving to :mod:`rlchain.rl_games` in this process only (:mod:`.alias`). The
first line printed says that rlchain stands in for rl_games.
"""

from __future__ import annotations

import os
import runpy
import sys

from rlchain.rl_games.alias import install
from rlchain.version import __version__

USAGE = "usage: python -m rlchain.rl_games SCRIPT [ARGS...]  (runs SCRIPT with rlchain standing in for rl_games)"


def main(argv: list[str] | None = None) -> int:
    """Run the script named by ``argv[0]`` with the alias installed; returns 2 on a bad launch line.
    The script's own ``sys.exit`` (or exception) ends the process as under plain ``python``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(USAGE, file=sys.stderr if not argv else sys.stdout)
        return 2 if not argv else 0
    script = argv[0]
    if not os.path.isfile(script):
        print(f"python -m rlchain.rl_games: {script}: no such script file ({USAGE})", file=sys.stderr)
        return 2
    print(f"rlchain {__version__} stands in for rl_games: running {script} with 'import rl_games' "
          f"resolved to rlchain.rl_games", flush=True)
    install()
    sys.argv = [script, *argv[1:]]
    sys.path[0] = os.path.dirname(os.path.abspath(script))  # as `python SCRIPT` sets it
    runpy.run_path(script, run_name="__main__")
    return 0


if __name__ == "__main__":
    sys.exit(main())
