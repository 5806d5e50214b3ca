"""Throughput of two versions of rlchain side by side: this tree against another git revision, in one run.

A refactor promises "speed unchanged"; this is how it is checked. The other revision is checked out into a
temporary git worktree, and each version's own throughput.py runs there (it puts its own tree
first on ``sys.path``, so it imports that version of rlchain). The two alternate, ``--rounds`` times each, so a
change in the machine's load falls on both; the table gives each version's median steps/s and the ratio
this tree / base::

    python benchmarks/throughput/tree_compare.py --base 9a8d437 \\
        --cases gymnasium:CartPole-v1:64 envpool:HalfCheetah-v4:64 --threads 1 --rounds 3

``--threads N`` passes ``--threads N --update-threads N`` to both (a fixed thread count, so only the code
differs); without it each version plans its threads as it ships. ``--set KEY=VALUE`` (repeatable) applies a
config override to this tree only (through its throughput.py's ``--variants``), e.g. an option the base does
not have.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

if __package__ in (None, ""):  # run by path: this checkout's benchmarks first
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from benchmarks.common import REPO, load_average, throughput_script  # noqa: E402

METRICS = ("env_sps", "rollout_sps", "train_sps")


def run_throughput(tree: str, cases: list[str], seconds: float, threads: int | None,
                   sets: list[str] | None = None) -> list[dict]:
    """One ``throughput.py`` run of the rlchain in ``tree`` (with the config overrides ``sets``); its rows."""
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as fh:
        out = fh.name
    cmd = [sys.executable, throughput_script(tree), "--cases", *cases,
           "--seconds", str(seconds), "--json", out]
    if threads is not None:
        cmd += ["--threads", str(threads), "--update-threads", str(threads)]
    if sets:
        cmd += ["--variants", "head=" + ",".join(sets)]
    subprocess.run(cmd, cwd=tree, check=True, stdout=subprocess.DEVNULL)
    with open(out) as fh:
        rows = json.load(fh)
    os.unlink(out)
    return rows


def add_worktree(base: str) -> str:
    """A temporary git worktree of revision ``base`` (a one-line error when git cannot make it)."""
    worktree = tempfile.mkdtemp(prefix="rlchain_base_")
    made = subprocess.run(["git", "-C", REPO, "worktree", "add", "--detach", worktree, base],
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if made.returncode != 0:
        os.rmdir(worktree)
        reason = (made.stderr.strip().splitlines() or ["git worktree add failed"])[-1]
        raise SystemExit(f"tree_compare.py: --base {base}: no worktree of that revision ({reason})")
    return worktree


def check_imports_own_tree(tree: str) -> None:
    """Fail unless a script in ``tree`` imports ``tree``'s rlchain (not an installed copy of another)."""
    code = f"import sys; sys.path.insert(0, {tree!r}); import rlchain; print(rlchain.__file__)"
    found = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout.strip()
    if not os.path.realpath(found).startswith(os.path.realpath(tree) + os.sep):
        raise SystemExit(f"{tree}: imports rlchain from {found}, not from its own tree")


def medians(runs: list[list[dict]]) -> dict[tuple[str, int], dict[str, float]]:
    """Per case (env, num_envs): the median of each metric over the runs."""
    by_case: dict[tuple[str, int], dict[str, list[float]]] = {}
    for rows in runs:
        for row in rows:
            case = by_case.setdefault((row["env"], row["num_envs"]), {m: [] for m in METRICS})
            for m in METRICS:
                case[m].append(row[m])
    return {case: {m: statistics.median(v) for m, v in values.items()} for case, values in by_case.items()}


def table(base: str, new: dict, old: dict) -> str:
    """Side by side: each metric for base and this tree, and the ratio this / base."""
    head = f"{'env':<18} {'envs':>5} " + " ".join(f"{m + ' ' + base:>22} {m + ' HEAD':>18} {'ratio':>6}"
                                                   for m in METRICS)
    lines = [head, "-" * len(head)]
    for case in sorted(new):
        if case not in old:
            continue
        cells = " ".join(f"{old[case][m]:>22,.0f} {new[case][m]:>18,.0f} {new[case][m] / old[case][m]:>6.3f}"
                         for m in METRICS)
        lines.append(f"{case[0]:<18} {case[1]:>5} {cells}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--base", required=True, help="the git revision to compare against (e.g. a commit)")
    ap.add_argument("--cases", nargs="+", default=["gymnasium:CartPole-v1:64", "envpool:HalfCheetah-v4:64"])
    ap.add_argument("--seconds", type=float, default=3.0, help="time per measurement (throughput.py's)")
    ap.add_argument("--threads", type=int, default=None, help="fixed torch threads for both (default: as shipped)")
    ap.add_argument("--rounds", type=int, default=3, help="runs of each version, alternating (default 3)")
    ap.add_argument("--set", action="append", default=[], help="a config override for this tree only")
    args = ap.parse_args(argv)

    worktree = add_worktree(args.base)
    new_runs, old_runs = [], []
    try:
        check_imports_own_tree(worktree)
        load = load_average()
        for k in range(args.rounds):
            print(f"round {k + 1}/{args.rounds}: {args.base} ...", flush=True)
            old_runs.append(run_throughput(worktree, args.cases, args.seconds, args.threads))
            print(f"round {k + 1}/{args.rounds}: HEAD ...", flush=True)
            new_runs.append(run_throughput(REPO, args.cases, args.seconds, args.threads, args.set))
            for name, rows in ((args.base, old_runs[-1]), ("HEAD", new_runs[-1])):
                for row in rows:  # each run, so the spread behind the medians shows
                    print(f"  {name:>10} {row['env']:<18} " + " ".join(f"{m} {row[m]:>10,.0f}" for m in METRICS)
                          + f" warm-up {row.get('warmup_s', 0.0):.1f} s")  # compile_update compiles there
    finally:
        subprocess.run(["git", "-C", REPO, "worktree", "remove", "--force", worktree], check=False)
    print()
    print(table(args.base, medians(new_runs), medians(old_runs)))
    print(f"\nmedians of {args.rounds} alternating runs; threads {args.threads or 'as shipped'}; "
          f"{os.cpu_count()} cores; load average {load:.2f} before / {load_average():.2f} after")
    return 0


if __name__ == "__main__":
    sys.exit(main())
