"""Peak memory of one benchmark run: ``python -m rlchain.compare.peak_memory OUT.json -- train cfg ...`` runs
``rlchain`` with the arguments after ``--`` in this process, then writes its peaks to ``OUT.json``.

What is measured: the GPU's peak allocated memory (``torch.cuda.max_memory_allocated``, the largest over the
devices the run used) when the run initialised CUDA, and the process's peak resident set size (the CPU
peak) always. Each run is its own process, so the GPU counters start at zero for it (a reset before the run
would itself initialise CUDA on a CPU run).
"""

from __future__ import annotations

import json
import resource
import runpy
import sys
from typing import Any


def gpu_peak_mb() -> float | None:
    """The largest ``max_memory_allocated`` over the CUDA devices, in MB; None when CUDA was never initialised
    in this process (a CPU run) or torch is not loaded."""
    torch = sys.modules.get("torch")
    if torch is None or not torch.cuda.is_available() or not torch.cuda.is_initialized():
        return None
    return max(torch.cuda.max_memory_allocated(d) for d in range(torch.cuda.device_count())) / 2**20


def cpu_peak_rss_mb() -> float:
    """This process's peak resident set size in MB (Linux reports kilobytes)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def peaks() -> dict[str, Any]:
    """``{"cpu_peak_rss_mb", "gpu_peak_memory_mb"}`` of this process so far (the GPU one None on a CPU run)."""
    return {"cpu_peak_rss_mb": cpu_peak_rss_mb(), "gpu_peak_memory_mb": gpu_peak_mb()}


def reported(record: dict[str, Any]) -> tuple[float | None, str]:
    """The peak a report shows for one run and its kind: the GPU's when the run used CUDA, else the CPU RSS."""
    if record.get("gpu_peak_memory_mb") is not None:
        return float(record["gpu_peak_memory_mb"]), "gpu"
    value = record.get("cpu_peak_rss_mb")
    return (float(value) if value is not None else None), "cpu_rss"


def main(argv: list[str]) -> int:
    if len(argv) < 2 or argv[1] != "--":
        print("usage: python -m rlchain.compare.peak_memory OUT.json -- RLCHAIN_ARGS...", file=sys.stderr)
        return 2
    out, args = argv[0], argv[2:]
    sys.argv = ["rlchain", *args]
    status = 0
    try:  # the console entry point, run as ``python -m rlchain`` would (not imported: entry points sit above)
        runpy.run_module("rlchain", run_name="__main__", alter_sys=True)
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    with open(out, "w", encoding="utf-8") as fh:
        json.dump(peaks(), fh)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
