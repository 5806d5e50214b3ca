"""``python -m rlchain.compare RUNS...``: the same as ``rlchain compare RUNS...``."""

import sys

from rlchain.compare.cli import main

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
