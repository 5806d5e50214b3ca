"""What the benchmark scripts share: where the repository and the results are, which CPU ran them.

Results go under ``results_dir()`` (``benchmarks/results/`` by default, ignored by git; ``RLCHAIN_BENCH_RESULTS``
moves it). Only the tables and plots the docs show are committed, under ``docs/img/``.

A script run by its path (``python benchmarks/peers/curves.py``) starts with::

    if __package__ in (None, ""):  # run by path: this checkout's benchmarks and rlchain first
        sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))

so ``benchmarks`` and ``rlchain`` come from the checkout the script is in (tree_compare.py relies on it to time
an older checkout's rlchain with that checkout's own throughput.py).
"""

from __future__ import annotations

import os
import platform
import subprocess

BENCH = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(BENCH)
CONFIGS = os.path.join(REPO, "rlchain", "configs")  # rlchain's shipped YAMLs
RL_GAMES_CONFIGS = os.path.join(BENCH, "rl_games_configs")  # rl_games' own YAMLs (a link to rlchain/configs/rl_games)
DOCS_IMG = os.path.join(REPO, "docs", "img")  # the plots the docs show (MkDocs serves only docs/)


def results_dir(*parts: str) -> str:
    """Where one script's results go (the script makes the folder): under ``$RLCHAIN_BENCH_RESULTS``, else
    benchmarks/results/."""
    return os.path.join(os.environ.get("RLCHAIN_BENCH_RESULTS") or os.path.join(BENCH, "results"), *parts)


def cpu_model() -> str:
    """lscpu's model name: machines here differ by up to 1.5x, so every figure names the CPU it ran on."""
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
        for line in out.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except (OSError, subprocess.CalledProcessError):
        pass
    return platform.processor() or "unknown"


def load_average() -> float:
    """The 1-minute load average (what else was running); NaN where the OS has none."""
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")


def throughput_script(tree: str) -> str:
    """``tree``'s throughput.py: benchmarks/throughput/throughput.py, or benchmarks/throughput.py in a checkout
    from before the benchmarks were grouped into folders (tree_compare.py and epoch_cpu.py time older trees)."""
    grouped = os.path.join(tree, "benchmarks", "throughput", "throughput.py")
    return grouped if os.path.exists(grouped) else os.path.join(tree, "benchmarks", "throughput.py")
