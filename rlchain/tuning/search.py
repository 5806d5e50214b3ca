"""``--tune``: run a search file on its backend (Optuna, or Ray Tune with ``backend: ray``).

    python runner.py --tune search.yaml            # or: python -m rlchain.tuning.search search.yaml
"""

from __future__ import annotations

import argparse
import sys

from rlchain.config.errors import ConfigError
from rlchain.tuning.common import load_search
from rlchain.tuning.optuna_search import run_optuna_search
from rlchain.tuning.ray_search import run_ray_search


def run_search(search_path: str, output: str | None = None,
               train_dir: str | None = None) -> tuple[float, str]:
    """Run the search; returns (best value, path of the written best config)."""
    spec = load_search(search_path)
    if spec.backend == "ray":
        return run_ray_search(spec, output, train_dir)
    return run_optuna_search(spec, output, train_dir)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m rlchain.tuning.search",
                                description="Hyperparameter search over a config")
    p.add_argument("search", help="search file (YAML)")
    p.add_argument("-o", "--output",
                   help="best config to write (default: <base name>_best.yaml in the search's run folder)")
    p.add_argument("--train_dir", help="folder for the trial runs (default: the base config's train_dir)")
    args = p.parse_args(argv)
    try:
        run_search(args.search, args.output, args.train_dir)
    except ConfigError as exc:
        print(f"config error: {exc}", file=sys.stderr)
        return 2
    except ImportError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
