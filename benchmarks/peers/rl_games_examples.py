"""Run every rl_games example config through rlchain for one epoch and print a Markdown table.

    python benchmarks/peers/rl_games_examples.py --configs /path/to/site-packages/rl_games/configs \\
        [--only atari,test] [--skip smac] [--timeout 180] [--jobs 1] [--out benchmarks/peers/rl_games_examples.md]

Each config runs as written (``runner.py --train --file X``) with only ``max_epochs=1``, a
temporary ``train_dir`` and ``device: cpu`` added. The outcome is one of:

- ``runs``: one epoch trained and a checkpoint was written;
- ``env not available``: the config is accepted, but its environment (Isaac Gym, Brax, SMAC, ...)
  is not installable here or not registered;
- ``not supported``: rlchain stops with a config error naming a key it does not implement;
- ``typo or unknown key caught``: a key rl_games silently ignores (e.g. a misspelt ``rnn1``);
- ``needs torchrun`` (``multi_gpu: True``);
- ``network not in rlchain``: e.g. rl_games' ``resnet_actor`` or ``tcnnnet`` (its test networks
  ``testnet`` / ``testnet_aux_loss`` are built into rlchain);
- ``timed out``: no epoch within ``--timeout`` seconds;
- ``error``: anything else (the first line of the message is shown).

``--jobs N`` runs N configs at a time (each niced); rows are printed as they finish and the table is
sorted by config name.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import glob
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENV_MISSING = ("unknown env", "is not installed", "no module named", "not registered", "namenotfound",
               "doesn't exist", "does not exist", "env_name", "environment", "cannot import", "dependency")


def classify(returncode: int, output: str) -> tuple[str, str]:
    """(outcome, detail) from the runner's exit code and output."""
    lines = [line for line in output.splitlines() if line.strip() and not line.startswith("warning:")]
    detail = next((line for line in reversed(lines) if "error" in line.lower()), lines[-1] if lines else "")
    if returncode == 0:
        return "runs", ""
    low = detail.lower()
    if "torchrun" in low:
        return "needs torchrun", detail
    if "unknown network" in low or "unknown model" in low:
        return "network not in rlchain", detail
    if "config error" in low and "not implemented" in low:
        return "not supported", detail
    if "config error" in low and "unknown key" in low:
        return "typo or unknown key caught", detail
    if any(marker in low for marker in ENV_MISSING):
        return "env not available", detail
    return "error", detail


def run_one(path: str, timeout: int) -> tuple[str, str, float]:
    start = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, os.path.join(ROOT, "runner.py"), "--train", "--file", path,
               "params.config.max_epochs=1", f"params.config.train_dir={tmp}", "params.config.device=cpu"]
        try:
            out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=tmp,
                                 preexec_fn=lambda: os.nice(10))
        except subprocess.TimeoutExpired:
            return "timed out", f"no epoch within {timeout} s", time.time() - start
        outcome, detail = classify(out.returncode, out.stdout + "\n" + out.stderr)
        if outcome == "runs" and not glob.glob(os.path.join(tmp, "**", "*.pth"), recursive=True):
            outcome, detail = "error", "finished without a checkpoint"
    return outcome, detail, time.time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--configs", required=True, help="rl_games' configs folder")
    parser.add_argument("--only", default="", help="comma-separated sub-folders or file-name parts to keep")
    parser.add_argument("--skip", default="", help="comma-separated sub-folders or file-name parts to leave out")
    parser.add_argument("--timeout", type=int, default=180)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--out", default="")
    args = parser.parse_args()
    paths = sorted(glob.glob(os.path.join(args.configs, "**", "*.yaml"), recursive=True))
    if args.only:
        keep = args.only.split(",")
        paths = [p for p in paths if any(k in os.path.relpath(p, args.configs) for k in keep)]
    if args.skip:
        drop = args.skip.split(",")
        paths = [p for p in paths if not any(k in os.path.relpath(p, args.configs) for k in drop)]
    # Atari's convolutional epochs are the slowest on a CPU: queue them last so the quick outcomes come first.
    paths.sort(key=lambda p: (os.path.relpath(p, args.configs).startswith("atari"), p))
    rows, counts = {}, {}
    with concurrent.futures.ThreadPoolExecutor(max(1, args.jobs)) as pool:
        futures = {pool.submit(run_one, path, args.timeout): os.path.relpath(path, args.configs)
                   for path in paths}
        for future in concurrent.futures.as_completed(futures):
            name = futures[future]
            outcome, detail, seconds = future.result()
            counts[outcome] = counts.get(outcome, 0) + 1
            rows[name] = f"| {name} | {outcome} | {seconds:.0f} | {detail.replace('|', '/')[:160]} |"
            print(rows[name], flush=True)
    table = ["| rl_games config | outcome | s | detail |", "|---|---|---|---|", *(rows[k] for k in sorted(rows)), "",
             "Totals: " + ", ".join(f"{k}: {v}" for k, v in sorted(counts.items()))]
    print("\n".join(table[-1:]))
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write("\n".join(table) + "\n")


if __name__ == "__main__":
    main()
