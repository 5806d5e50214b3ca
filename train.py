"""Alternative entry point: ``python train.py --config configs/.../train_config.json [key.path=value ...]``.

The same as ``python runner.py --train --file <config>``; YAML works too, and so does EmbodiChain's layout
(``trainer`` / ``policy`` / ``algorithm``, docs/embodichain.md). ``--distributed`` (EmbodiChain's flag, under
``torchrun``) is ``params.config.multi_gpu``.
"""

import argparse
import sys

from rlchain.cli import main

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", required=True, help="JSON or YAML config")
    parser.add_argument("-c", "--checkpoint", help="resume from this checkpoint")
    parser.add_argument("--distributed", action=argparse.BooleanOptionalAction, default=None,
                        help="torch.distributed training under torchrun (params.config.multi_gpu)")
    args, rest = parser.parse_known_args()
    argv = ["--train", "--file", args.config] + (["--checkpoint", args.checkpoint] if args.checkpoint else [])
    if args.distributed is not None:
        rest.append(f"params.config.multi_gpu={str(args.distributed).lower()}")
    sys.exit(main(argv + rest))
