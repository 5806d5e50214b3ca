"""Find each peer's best settings on this machine: rl_games 1.6.5 and 2.0 under every thread / compile setting.

``curves.py`` compares rlchain with each rl_games version "at its best". What is best on a small CPU is
measured here, not assumed: one YAML, one seed, every combination of the torch thread count (default,
``OMP_NUM_THREADS=1``, ``=2``) and ``torch_compile`` (the YAML's default, on; off) for each rl_games
version, and rlchain as shipped, one run at a time for the same wall-clock budget. It prints frames/s
(from process start, so compile time counts), the reward at the end and the reward at a frame count
every run reached, side by side, with the CPU model and the load average around each run.

Example (about 15 minutes on 2 cores)::

    python benchmarks/peers/peer_settings.py --config hopper --seconds 90 --seed 11

The settings ``curves.py`` calls ``rl_games`` / ``rl_games2`` (its ``SYSTEMS``) should be the fastest
rows here; the table goes into docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import os
import sys

if __package__ in (None, ""):  # run by path: this checkout's benchmarks and rlchain first
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from benchmarks.peers import curves  # noqa: E402

# rl_games itself calls torch.set_num_threads(params.torch_threads, default min(4, cores)): the environment
# variables set OpenMP/MKL's defaults, which that call then overrides (2 torch threads on 2 cores), so only
# torch_threads (rl_games_driver.py --torch-threads) gives it one torch thread.
THREADS = {  # key -> (what a reader is told, environment, driver arguments)
    "tdefault": ("default threads (torch: 2 on 2 cores)", (), ()),
    "t1": ("OMP_NUM_THREADS=1 (torch: 2 on 2 cores)", (("OMP_NUM_THREADS", "1"), ("MKL_NUM_THREADS", "1")), ()),
    "t2": ("OMP_NUM_THREADS=2 (torch: 2)", (("OMP_NUM_THREADS", "2"), ("MKL_NUM_THREADS", "2")), ()),
    "tt1": ("torch_threads: 1, OMP_NUM_THREADS=1", (("OMP_NUM_THREADS", "1"), ("MKL_NUM_THREADS", "1")),
            ("--torch-threads", "1")),
}
COMPILE = {"compile": ("compile on", ("--torch-compile", "on")),
           "nocompile": ("compile off", ("--torch-compile", "off"))}


def settings(libs: list[str]) -> dict[str, curves.System]:
    """Every (version, threads, compile) combination as a named system, rlchain first."""
    out = {"rlchain": curves.SYSTEMS["rlchain"]}
    for lib in libs:
        for tkey, (threads, env, thread_args) in THREADS.items():
            for ckey, (compiled, args) in COMPILE.items():
                out[f"{lib}_{tkey}_{ckey}"] = curves.System(lib, f"{threads}, {compiled}", args + thread_args, env)
    return out


def table(runs: dict[str, dict]) -> list[str]:
    """One markdown row per setting: frames/s, reward at the end, reward at the frames every run reached."""
    common = min(run["events"][-1][1] for run in runs.values())
    lines = ["| system | setting | frames/s | vs rlchain | reward at end | reward at "
             f"{common / 1e6:.2f}M frames | load before / after |", "|---|---|---|---|---|---|---|"]
    ours = curves.fps(runs["rlchain"]) if "rlchain" in runs else None
    for name, run in runs.items():
        system = curves.SYSTEMS[name]
        rate = curves.fps(run)
        versus = f"{rate / ours:.2f}x" if ours else "-"
        lines.append(f"| {system.lib} | {system.setting} | {rate:,.0f} | {versus} | {run['events'][-1][2]:.0f} | "
                     f"{curves.value_at(run['events'], common, 1):.0f} | "
                     f"{run['load_before']:.1f} / {run['load_after']:.1f} |")
    return lines


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--config", choices=sorted(curves.CONFIGS), default="hopper")
    p.add_argument("--seed", type=int, default=11)
    p.add_argument("--seconds", type=float, default=90.0)
    p.add_argument("--libs", nargs="+", choices=("rl_games", "rl_games2"), default=["rl_games", "rl_games2"])
    p.add_argument("--only", nargs="*", default=None, help="run only these setting names (see --list)")
    p.add_argument("--list", action="store_true", help="print the setting names and exit")
    p.add_argument("--rl-games-python", default="/work/rlg-venv/bin/python")
    p.add_argument("--rl-games2-python", default="/work/rlg2-venv/bin/python")
    p.add_argument("--rlchain-python", default=sys.executable)
    p.add_argument("--out", default=None, help="also write the table to this markdown file")
    args = p.parse_args(argv)
    args.rlchain_args = args.rl_games_args = ""
    systems = settings(args.libs)
    if args.list:
        print("\n".join(systems))
        return 0
    curves.SYSTEMS.update(systems)
    runs = {}
    for name in systems:
        if args.only is not None and name not in args.only:
            continue
        try:
            runs[name] = curves.train_for(name, args.config, args.seed, args.seconds, args)
        except RuntimeError as exc:  # no reward in the budget (compilation can take that long): said
            print(exc, file=sys.stderr, flush=True)
    lines = [f"CPU: {curves.cpu_model()}; {args.config}, seed {args.seed}, {args.seconds:g} s per run from process "
             "start, one run at a time", "", *table(runs)]
    print("\n".join(lines))
    if args.out:
        with open(args.out, "w") as f:
            f.write("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
