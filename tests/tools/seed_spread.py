"""Seed spread of the learning tests: each named learning test run on several seeds, and what each of its training
runs ended with (the frames it stopped at, why, its rewards), as a markdown table (docs/layout.md keeps one).

A learning test stops at its score (score_to_win, success_to_win): the frames a seed stopped at are the frames it
needed; a test that trains a fixed budget and then plays says its score at the bound. The seed reaches every run
a test trains through tests/conftest.py (``RLCHAIN_LEARNING_SEED``: ``Runner.train``'s seed, the SB3 face's too);
``default`` runs the test as it is (its config's seed). Tests that train through no ``Runner`` (the RLlib face)
report pass / fail only.

    python tests/tools/seed_spread.py tests/learning/test_learning.py::test_ppo_cartpole_reaches_475
    python tests/tools/seed_spread.py --seeds default,1,2 --workers 2 tests/learning   # the whole tier, 3 times
    python tests/tools/seed_spread.py --out spread/ -k cartpole tests/learning         # keep the raw files

Each seed is one ``pytest -m slow`` run (``--workers`` of one torch thread each, as the tier). Pass the budget
you measure (``-o`` / ``-k`` go to pytest as they are); the frames a seed needs are load-independent, its
seconds are not.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ElementTree

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def run_seed(seed: str, tests: list[str], workers: int, out: str) -> tuple[str, str, float]:
    """Run ``tests`` (pytest arguments) with ``seed``; (junit report, results file, seconds)."""
    junit, results = os.path.join(out, f"seed_{seed}.xml"), os.path.join(out, f"seed_{seed}.jsonl")
    open(results, "w").close()
    env = {**os.environ, "PYTHONPATH": ROOT, "OMP_NUM_THREADS": "1", "RLCHAIN_LEARNING_RESULTS": results}
    env.pop("RLCHAIN_LEARNING_SEED", None)
    if seed != "default":
        env["RLCHAIN_LEARNING_SEED"] = seed
    parallel = ["-n", str(workers), "--dist", "worksteal"] if workers > 1 else []
    start = time.time()
    # no wall-clock timeout: on a loaded machine it cuts the runs whose frames are what this measures
    subprocess.run([sys.executable, "-m", "pytest", "-q", "-m", "slow", "-p", "no:cacheprovider", "-p", "no:timeout",
                    *parallel,
                    f"--junitxml={junit}", *tests], cwd=ROOT, env=env)
    return junit, results, time.time() - start


def outcomes(junit: str) -> dict[str, tuple[str, float]]:
    """test node id -> (passed / failed / skipped, seconds) from a junit report."""
    found = {}
    if not os.path.exists(junit):
        return found
    for case in ElementTree.parse(junit).iter("testcase"):
        path = case.get("classname", "").replace(".", "/")
        node = f"{path}.py::{case.get('name')}"
        verdict = "passed"
        for child in case:
            if child.tag in ("failure", "error"):
                verdict = "failed"
            elif child.tag == "skipped":
                verdict = "skipped"
        found[node] = (verdict, float(case.get("time", 0.0)))
    return found


def frames(n: int) -> str:
    return f"{n / 1e6:.2f}M" if n >= 1e6 else f"{n / 1e3:.1f}k" if n >= 1e3 else str(n)


def reached(curve: list, bar: float) -> str:
    """The frames at which a run's mean episode reward first reached ``bar`` ('-' if it never did)."""
    return next((frames(f) for f, value in curve if value >= bar), "-")


def cell(verdict: str, seconds: float, runs: list[dict], bars: list[float]) -> str:
    """One seed of one test: its verdict, each run's frames, why it stopped and its reward (and the frames each of
    ``bars`` was first reached at), each play's mean reward, the test's seconds."""
    if verdict == "skipped":
        return "skipped"
    parts = []
    for run in runs:
        if "played" in run:  # a Runner.play after the training: its mean reward
            parts.append(f"played {run['played']:.3g}")
            continue
        stop = run["stop"].split(" ")[0]
        lower = "".join(f", {bar:g} at {reached(run.get('curve', []), bar)}" for bar in bars)
        parts.append(f"{frames(run['frames'])} ({stop}, {run['mean_reward']:.3g}{lower})")
    return f"{verdict}: {'; '.join(parts) or 'no Runner run'} {seconds:.0f} s"


def comma_list(text: str) -> list[str]:
    """``default,1,2`` -> ['default', '1', '2'] (an option's values in one word: every other word is pytest's)."""
    items = [item.strip() for item in text.split(",") if item.strip()]
    if not items:
        raise argparse.ArgumentTypeError(f"expected a comma-separated list, got {text!r}")
    return items


def bars(text: str) -> list[float]:
    """``300,400`` -> [300.0, 400.0]."""
    try:
        return [float(item) for item in comma_list(text)]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None


def parse_args(argv: list[str] | None = None) -> tuple[argparse.Namespace, list[str]]:
    """(the options, the pytest arguments: test ids, files, -k / -o ...). Each option takes one word (its list
    comma-separated), so a test id after ``--seeds`` or ``--reach`` stays a test id."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=comma_list, default=["default", "1", "2"],
                        help="comma-separated seeds to run each test with; 'default': the test's own "
                             "(default: default,1,2)")
    parser.add_argument("--workers", type=int, default=1, help="pytest-xdist workers (default 1)")
    parser.add_argument("--out", help="a folder to keep the junit reports and results files in")
    parser.add_argument("--again", action="store_true",
                        help="run nothing: print the table of the reports already in --out (other --reach bars)")
    parser.add_argument("--reach", type=bars, default=[],
                        help="comma-separated (lower) bars: also say where each run's mean episode reward first "
                             "reached each")
    args, tests = parser.parse_known_args(argv)
    stray = [t for t in tests if t.lstrip("-").replace(".", "", 1).isdigit()]
    if stray:  # the old space-separated form (--seeds default 1 2): a bare number is no test id
        parser.error(f"{' '.join(stray)}: not a test id; --seeds and --reach take one comma-separated list "
                     f"(--seeds default,1,2 --reach 300,400)")
    if not tests and not args.again:
        parser.error("name the learning tests (files, node ids, -k ...)")
    if args.again and not args.out:
        parser.error("--again reads the reports in --out")
    return args, tests


def main() -> int:
    args, tests = parse_args()
    out = args.out or tempfile.mkdtemp(prefix="rlchain-seed-spread-")
    os.makedirs(out, exist_ok=True)
    table: dict[str, dict[str, str]] = collections.defaultdict(dict)
    for seed in args.seeds:
        if args.again:
            junit, results, seconds = os.path.join(out, f"seed_{seed}.xml"), os.path.join(out, f"seed_{seed}.jsonl"), 0
            if not os.path.exists(results):
                continue
        else:
            junit, results, seconds = run_seed(seed, tests, args.workers, out)
        runs = collections.defaultdict(list)
        with open(results) as f:
            for line in f:
                run = json.loads(line)
                runs[run["test"]].append(run)
        for node, (verdict, test_seconds) in outcomes(junit).items():
            table[node][seed] = cell(verdict, test_seconds, runs.get(node, []), args.reach)
        print(f"seed {seed}: {len(outcomes(junit))} tests in {seconds:.0f} s ({out})", flush=True)
    print(f"\n| test | {' | '.join(f'seed {s}' for s in args.seeds)} |")
    print(f"|---|{'---|' * len(args.seeds)}")
    for node in sorted(table):
        print(f"| `{node.split('/')[-1]}` | {' | '.join(table[node].get(s, '-') for s in args.seeds)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
