"""``python -m rlchain.rl_games SCRIPT [ARGS...]``: run an rl_games script unchanged on rlchain.

The script runs as ``python SCRIPT ARGS`` would run it (``sys.argv`` is ``[SCRIPT, *ARGS]``, it runs as
``__main__``, its folder is first on ``sys.path``, its exit code is the process's), with
``import rl_games...`` resolving to :mod:`rlchain.rl_games` in this process only (:mod:`.alias`). The
first line printed says that rlchain stands in for rl_games.
"""

from __future__ import annotations

import sys

from rlchain.faces import run_script
from rlchain.rl_games.alias import RlGamesAlias


def main(argv: list[str] | None = None) -> int:
    """Run the script named by ``argv[0]`` (:func:`rlchain.faces.run_script`)."""
    return run_script(argv, "rlchain.rl_games", "rl_games", RlGamesAlias)


if __name__ == "__main__":
    sys.exit(main())
