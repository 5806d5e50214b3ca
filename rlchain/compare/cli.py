"""``rlchain compare RUNS...`` (also ``python -m rlchain.compare``): seed-aggregated curves and an IQM table.

Examples::

    rlchain compare runs/ppo_cartpole_* runs/ppo_cartpole_rnn_*          # grouped by run name
    rlchain compare 'ppo=runs/a_*' 'sac=runs/b_*' --at-frames 100k 500k  # LABEL=GLOB names a group
    rlchain compare runs/ --label-by config --tag reward success env_info/reward_box_target

writes ``OUT/compare.md`` (also printed) and one PNG per tag (``OUT/rewards_step.png`` ...).
"""

from __future__ import annotations

import argparse
import os
import re
import sys

from rlchain.compare.plot import BANDS, plot_tag, slug
from rlchain.compare.report import Settings, report
from rlchain.compare.runs import LABEL_BY, CompareError, groups, load_runs, resolve_tags
from rlchain.compare.stats import STATISTICS

SUFFIXES = {"k": 1e3, "m": 1e6, "g": 1e9}


def amount(text: str) -> float:
    """``500000``, ``5e5``, ``500k``, ``1.5M`` -> a float (argparse type: a bad one is its one-line error)."""
    match = re.fullmatch(r"\s*([0-9.]+(?:e[+-]?\d+)?)\s*([kmg]?)\s*", text.lower())
    if not match:
        raise argparse.ArgumentTypeError(f"expected a number such as 500000, 5e5, 500k or 1.5M, got '{text}'")
    try:
        value = float(match.group(1)) * SUFFIXES.get(match.group(2), 1.0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number such as 500000, 5e5, 500k or 1.5M, got '{text}'") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got '{text}'")
    return value


class _Parser(argparse.ArgumentParser):
    """argparse, with a bad argument a CompareError (one line) instead of the usage block and an exit."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise CompareError(f"{message} (rlchain compare --help)")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="rlchain compare", description="Compare training runs: curves against "
                                "frames and seconds with seed bands, and a Markdown table of IQM with bootstrap "
                                "confidence intervals.")
    p.add_argument("runs", nargs="+", metavar="RUNS", help="run folders, globs or train_dirs (runs/); "
                   "LABEL=GLOB labels a group")
    p.add_argument("--label-by", choices=LABEL_BY, default="name",
                   help="group runs by the folder name without its date-time (name, default), by params.config.name "
                        "in its config.yaml (config) or by the argument that matched it (glob: quote the glob)")
    p.add_argument("--tag", nargs="+", default=[], metavar="TAG",
                   help="scalars to compare (default: rewards/step, episodes/success_rate when logged, every "
                        "env_info/*); short names: reward, success")
    p.add_argument("--at-frames", nargs="+", type=amount, metavar="N", help="table rows at these frames "
                   "(default: 4 even points up to the shortest run)")
    p.add_argument("--at-seconds", nargs="+", type=amount, metavar="S", help="table rows at these seconds "
                   "from each run's start (default: 4 even points)")
    p.add_argument("--out", default="compare", help="folder for compare.md and the PNGs (default: ./compare)")
    p.add_argument("--statistic", choices=sorted(STATISTICS), default="iqm", help="over runs (default: iqm)")
    p.add_argument("--confidence", type=float, default=0.95, help="of the bootstrap interval (default 0.95)")
    p.add_argument("--reps", type=int, default=2000, help="bootstrap resamples (default 2000)")
    p.add_argument("--seed", type=int, default=0, help="of the bootstrap (default 0: the same table every time)")
    p.add_argument("--band", choices=BANDS, default="minmax", help="the plots' band around the mean over seeds: "
                   "minmax (default), ci (95%% bootstrap interval of the mean) or std")
    p.add_argument("--no-plot", action="store_true", help="the table only (no matplotlib needed)")
    return p


def run(args: argparse.Namespace) -> str:
    """Load, group, tabulate and plot; returns the Markdown (also written to ``OUT/compare.md``)."""
    if not 0.0 < args.confidence < 1.0:
        raise CompareError(f"--confidence: expected a value in (0, 1), got {args.confidence}")
    if args.reps < 1:
        raise CompareError(f"--reps: expected a positive count, got {args.reps}")
    runs = load_runs(args.runs, args.label_by)
    tags = resolve_tags(args.tag, runs)
    by_label = groups(runs)
    os.makedirs(args.out, exist_ok=True)
    images: dict[str, str] = {}
    if not args.no_plot:
        for tag in tags:
            name = f"{slug(tag)}.png"
            plot_tag(by_label, tag, os.path.join(args.out, name), band=args.band)
            images[tag] = name
    settings = Settings(args.statistic, args.confidence, args.reps, args.seed)
    text = report(by_label, tags, args.at_frames, args.at_seconds, settings, images)
    with open(os.path.join(args.out, "compare.md"), "w", encoding="utf-8") as fh:
        fh.write(text)
    return text


def main(argv: list[str] | None = None) -> int:
    """``rlchain compare``'s entry: 0 when the report was written, 2 on bad input (one line on stderr)."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help
        return int(exc.code or 0)
    except CompareError as exc:
        print(f"rlchain compare: error: {exc}", file=sys.stderr)
        return 2
    try:
        text = run(args)
    except CompareError as exc:
        print(f"rlchain compare: error: {exc}", file=sys.stderr)
        return 2
    print(text, end="")
    print(f"written: {os.path.join(args.out, 'compare.md')}" +
          ("" if args.no_plot else f" and {len(tags_in(text))} PNG(s) in {args.out}"), file=sys.stderr)
    return 0


def tags_in(text: str) -> list[str]:
    """The tags the report has a section for."""
    return [line[4:] for line in text.splitlines() if line.startswith("### ")]


__all__ = ["main", "build_parser", "run", "amount"]
