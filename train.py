"""Alternative entry point: ``python train.py --config configs/.../train_config.json [key.path=value ...]``.

The same as ``python runner.py --train --file <config>``; YAML works too.
"""

import argparse
import sys

from rlchain.cli import main

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", required=True, help="JSON or YAML config")
    parser.add_argument("-c", "--checkpoint", help="resume from this checkpoint")
    args, rest = parser.parse_known_args()
    argv = ["--train", "--file", args.config] + (["--checkpoint", args.checkpoint] if args.checkpoint else [])
    sys.exit(main(argv + rest))
