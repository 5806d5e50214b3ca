"""``python -m rlchain``: the same as the ``rlchain`` console script (rlchain.console)."""

import sys

from rlchain.console import main

if __name__ == "__main__":
    sys.exit(main())
