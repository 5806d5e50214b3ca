"""rl_games-style command line: python runner.py --train --file rlchain/configs/ppo_cartpole.yaml"""

import sys

from rlchain.cli import main

if __name__ == "__main__":
    sys.exit(main())
