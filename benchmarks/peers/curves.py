"""Learning curves, rlchain against rl_games: reward against frames and against wall-clock seconds.

For each rl_games YAML, each seed and each library, one training run for the same wall-clock
budget, one process at a time (so neither library shares the CPU with the other). Each run gets a
copy of the YAML with ``params.seed`` and ``params.config.env_config.seed`` set to the seed and
nothing else changed. The TensorBoard ``rewards/step`` events of every run (wall time, frames,
mean reward over the last ``games_to_track`` episodes) are saved as JSON under ``--out``, and from
them the script writes, per config:

* a table of mean +- standard deviation over seeds of the reward at fixed frame counts and at fixed
  times, frames/s, and the ratio rlchain / rl_games (``results.md``, also printed);
* a PNG with reward vs frames and reward vs seconds, both libraries, the seed band shaded;
* per config, the IQM over seeds with its 95% bootstrap interval at the same points (``rlchain compare``'s
  table: the curves, the statistics and the plots are rlchain/compare's, this script adds the runs,
  the ratios and the verdicts).

``--frames N`` caps every run at N env frames as well (rlchain: ``params.config.max_frames``; rl_games:
``--max-epochs``, N / (horizon_length * num_actors) rounded up): reward per frame does not depend on the
machine's load, so a frame budget compares learning on a busy machine.

Runs already saved with the same budget are reused (``--rerun`` trains them again), so the
table and plots regenerate from the saved runs with ``--plot-only``. Every results file records the
CPU model and the load average before and after each run.

Example (all defaults: the six configs, 3 seeds, 300 s each; about 3 hours on 2 cores)::

    python benchmarks/peers/curves.py --rl-games-python /work/rlg-venv/bin/python

Needs matplotlib in the interpreter that runs this script (``pip install -e ".[bench]"``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

import yaml

if __package__ in (None, ""):  # run by path: this checkout's benchmarks and rlchain first
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from benchmarks.common import BENCH, DOCS_IMG, REPO, cpu_model, load_average, results_dir  # noqa: E402
from benchmarks.peers.compare import read_rewards, stop  # noqa: E402
from rlchain.compare.plot import plot_tag  # noqa: E402
from rlchain.compare.report import Settings, table  # noqa: E402
from rlchain.compare.runs import REWARD, Curve, Run, curve_from_events  # noqa: E402

HERE = BENCH  # CONFIGS' paths are relative to benchmarks/
DRIVER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "rl_games_driver.py")
CONFIGS = {  # short name -> rl_games' own YAML (device: cpu added, nothing else changed)
    "ant": "rl_games_configs/ant_envpool.yaml",
    "halfcheetah": "rl_games_configs/halfcheetah_envpool.yaml",
    "hopper": "rl_games_configs/hopper_envpool.yaml",
    "walker2d": "rl_games_configs/walker2d_envpool.yaml",
    "humanoid": "rl_games_configs/humanoid_envpool.yaml",
    "pendulum": "rl_games_configs/ppo_pendulum_torch.yaml",
    # rlchain's tensor envs (batched torch math), rl_games reaching them through its vecenv API
    # (rl_games_tensor_env.py); score_to_win is dropped so every run trains for the whole budget
    "torch_pendulum": "../rlchain/configs/ppo_torch_pendulum.yaml",
    "torch_reacher8": "../rlchain/configs/ppo_torch_reacher8.yaml",
}
TENSOR_CONFIGS = ("torch_pendulum", "torch_reacher8")
DEFAULT_SEEDS = (11, 12, 13)


@dataclass(frozen=True)
class System:
    """One trainer as the benchmark runs it: which interpreter and driver, which settings."""

    lib: str  # "rlchain", "rl_games" (1.6.5, PyPI) or "rl_games2" (its main branch, 2.0)
    setting: str  # what a reader is told: "as shipped", "1 thread, compile off", ...
    driver_args: tuple[str, ...] = ()  # extra rl_games_driver.py arguments
    env: tuple[tuple[str, str], ...] = ()  # extra environment variables (thread counts)
    color: str = "tab:gray"
    overrides: tuple[str, ...] = ()  # rlchain: runner.py key=value overrides
    saved_as: str = ""  # the label its saved runs carry, where ``setting`` was corrected after they ran

    @property
    def run_label(self) -> str:
        """What a saved run of this system records (and is matched by): ``saved_as``, else ``setting``."""
        return self.saved_as or self.setting


ONE_THREAD = (("OMP_NUM_THREADS", "1"), ("MKL_NUM_THREADS", "1"))
# rl_games calls torch.set_num_threads(params.torch_threads, default min(4, cores)) itself, so "rl_games" /
# "rl_games2" below (OMP_NUM_THREADS=1) run 2 torch threads on 2 cores; saved runs of them carry the label
# "1 thread, compile off" (saved_as), so they still load. "*_tt1" is one torch thread for real
# (rl_games_driver.py --torch-threads 1). Each peer at its best on a 2-core CPU: compile off, one torch thread
# (peer_settings.py measures every setting of both versions side by side), and as shipped.
SYSTEMS = {
    "rlchain": System("rlchain", "as shipped", color="tab:blue"),
    "rlchain_bf16": System("rlchain", "mixed_precision: bf16 (the update's network passes in bfloat16 on an "
                                      "AMX / AVX512-BF16 CPU)", overrides=("params.config.mixed_precision=bf16",),
                           color="tab:purple"),
    "rlchain_compiled": System("rlchain", "compiled: compile_update + torch_compile",
                               overrides=("params.config.compile_update=True", "params.config.torch_compile=True"),
                               color="tab:pink"),
    "rl_games": System("rl_games", "OMP_NUM_THREADS=1 (2 torch threads), compile off", ("--torch-compile", "off"),
                       ONE_THREAD, "tab:orange", saved_as="1 thread, compile off"),
    "rl_games_shipped": System("rl_games", "as shipped (compile on, default threads)", color="tab:brown"),
    "rl_games2": System("rl_games2", "OMP_NUM_THREADS=1 (2 torch threads), compile off", ("--torch-compile", "off"),
                        ONE_THREAD, "tab:green", saved_as="1 thread, compile off"),
    "rl_games2_shipped": System("rl_games2", "as shipped (compile on, default threads)", color="tab:olive"),
    "rl_games_tt1": System("rl_games", "torch_threads: 1 (one torch thread), compile off",
                           ("--torch-compile", "off", "--torch-threads", "1"), ONE_THREAD, "tab:red"),
    "rl_games2_tt1": System("rl_games2", "torch_threads: 1 (one torch thread), compile off",
                            ("--torch-compile", "off", "--torch-threads", "1"), ONE_THREAD, "tab:cyan"),
}
PEERS = [name for name in SYSTEMS if name != "rlchain"]
COLORS = {name: system.color for name, system in SYSTEMS.items()}


def describe(name: str) -> str:
    """A system's name as tables and legends say it: library, version and setting."""
    system = SYSTEMS[name]
    version = {"rlchain": "", "rl_games": " 1.6.5", "rl_games2": " 2.0 (main)"}[system.lib]
    return f"{'rl_games' if system.lib != 'rlchain' else 'rlchain'}{version}, {system.setting}"


# ----- running -------------------------------------------------------------------------------
def seeded_config(path: str, seed: int, workdir: str, whole_budget: bool = False) -> str:
    """A copy of the YAML in ``workdir`` with params.seed and env_config.seed (if any) set to ``seed``;
    ``whole_budget``: without score_to_win, so the run does not stop when it reaches it."""
    with open(path) as f:
        cfg = yaml.safe_load(f)
    cfg["params"]["seed"] = seed
    if whole_budget:
        cfg["params"]["config"].pop("score_to_win", None)
    env_config = cfg["params"]["config"].get("env_config")
    if isinstance(env_config, dict):
        env_config["seed"] = seed
    out = os.path.join(workdir, os.path.basename(path))
    with open(out, "w") as f:
        yaml.safe_dump(cfg, f, sort_keys=False)
    return out


def frame_cap_args(lib: str, cfg_path: str, frames: int | None) -> list[str]:
    """The arguments that stop one library's run after ``frames`` env frames (none for None): rlchain's
    ``max_frames`` override, or rl_games' ``--max-epochs`` of horizon_length * num_actors frames each
    (rounded up, so rl_games plays at least ``frames``)."""
    if frames is None:
        return []
    if lib == "rlchain":
        return [f"params.config.max_frames={frames}"]
    with open(cfg_path) as f:
        config = yaml.safe_load(f)["params"]["config"]
    per_epoch = int(config["horizon_length"]) * int(config["num_actors"])
    return ["--max-epochs", str(math.ceil(frames / per_epoch))]


def command(name: str, cfg_path: str, args: argparse.Namespace, tensor_env: bool = False) -> list[str]:
    """The training command of one system, as a user of it would type it (``tensor_env``: the YAML names one
    of rlchain's tensor envs, which rl_games reaches through rl_games_tensor_env.py)."""
    system = SYSTEMS[name]
    cap = frame_cap_args(system.lib, cfg_path, getattr(args, "frames", None))
    if system.lib == "rlchain":
        return [args.rlchain_python, os.path.join(REPO, "runner.py"), "--train", "--file", cfg_path,
                *system.overrides, *shlex.split(args.rlchain_args), *cap]
    python = args.rl_games_python if system.lib == "rl_games" else args.rl_games2_python
    return [python, DRIVER, "--file", cfg_path, *system.driver_args,
            *(["--tensor-env"] if tensor_env else []), *shlex.split(args.rl_games_args), *cap]


def budget_of(config: str, args: argparse.Namespace) -> float:
    """Seconds of one run of ``config``: --pendulum-seconds, --tensor-seconds or --seconds."""
    if config == "pendulum":
        return args.pendulum_seconds
    return args.tensor_seconds if config in TENSOR_CONFIGS else args.seconds


def environment(name: str) -> dict[str, str]:
    """The process environment of one system's run: this one plus its settings (thread counts)."""
    return {**os.environ, **dict(SYSTEMS[name].env)}


def train_for(lib: str, config: str, seed: int, seconds: float, args: argparse.Namespace) -> dict:
    """One run for ``seconds`` of wall time from process start; its reward events and conditions."""
    workdir = tempfile.mkdtemp(prefix=f"curve_{config}_{lib}_{seed}_")
    tensor = config in TENSOR_CONFIGS
    cfg_path = seeded_config(os.path.join(HERE, CONFIGS[config]), seed, workdir, whole_budget=tensor)
    cmd = command(lib, cfg_path, args, tensor_env=tensor)
    env = dict(SYSTEMS[lib].env)
    print(f"[{config} {lib} seed {seed}] $ {' '.join(f'{k}={v}' for k, v in env.items())} {shlex.join(cmd)}",
          flush=True)
    load_before, accs = load_average(), {}
    with open(os.path.join(workdir, "train.log"), "wb") as log:
        t0 = time.time()
        proc = subprocess.Popen(cmd, cwd=workdir, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                start_new_session=True, env=environment(lib))
        try:
            while proc.poll() is None and time.time() - t0 < seconds:
                time.sleep(1.0)
        finally:
            stop(proc)
    wall = time.time() - t0
    events = [(w - t0, step, value) for w, step, value in read_rewards(workdir, accs) if w - t0 <= seconds]
    if not events:
        with open(os.path.join(workdir, "train.log"), "rb") as f:
            tail = f.read()[-2000:].decode(errors="replace")
        raise RuntimeError(f"[{config} {lib} seed {seed}] no rewards/step events (rc {proc.returncode}); "
                           f"log in {workdir}:\n{tail}")
    last = events[-1]
    print(f"[{config} {lib} seed {seed}] {last[1]} frames, reward {last[2]:.1f} at {last[0]:.0f} s", flush=True)
    shutil.rmtree(workdir, ignore_errors=True)  # the events are in the saved run; a failed run's folder stays
    return {"config": config, "lib": lib, "seed": seed, "budget_s": seconds,
            "budget_frames": getattr(args, "frames", None), "wall_s": wall,
            "events": events, "load_before": load_before, "load_after": load_average(), "cmd": cmd,
            "returncode": proc.returncode, "env": env,
            "setting": SYSTEMS[lib].run_label, "date": time.strftime("%Y-%m-%d %H:%M:%S")}


def run_path(runs_dir: str, config: str, lib: str, seed: int) -> str:
    return os.path.join(runs_dir, config, f"{lib}_seed{seed}.json")


def mismatch(run: dict, lib: str, budget: float, frames: int | None) -> str | None:
    """Why a saved run is not ``lib``'s run with this budget (seconds, and frames: None for none), or None."""
    if run["budget_s"] != budget or run.get("budget_frames") != frames:
        return (f"saved with --seconds {run['budget_s']:g} --frames {run.get('budget_frames')}, "
                f"asked for --seconds {budget:g} --frames {frames}")
    label = SYSTEMS[lib].run_label
    if run.get("env", {}) != dict(SYSTEMS[lib].env) or run.get("setting", label) != label:
        return f"saved under another setting ({run.get('setting', '?')}, env {run.get('env', {})})"
    return None


def load_runs(runs_dir: str, config: str, libs: list[str], seeds: list[int], budget: float,
              frames: int | None = None, skipped: list[str] | None = None) -> dict[str, list[dict]]:
    """The saved runs of ``config`` with this budget (seconds, and frames: None for none), by library;
    each saved file that is not one of them adds ``path: why`` to ``skipped`` when given."""
    runs: dict[str, list[dict]] = {lib: [] for lib in libs}
    for lib in libs:
        for seed in seeds:
            path = run_path(runs_dir, config, lib, seed)
            if os.path.exists(path):
                with open(path) as f:
                    run = json.load(f)
                why = mismatch(run, lib, budget, frames)
                if why is None:
                    runs[lib].append(run)  # a run saved under other settings is not this system's
                elif skipped is not None:
                    skipped.append(f"{path}: {why}")
    return runs


# ----- summarising (pure functions) -------------------------------------------------------------
def curve(run: dict) -> Curve:
    """A saved run's reward events as an rlchain.compare Curve; it went on until its time budget."""
    return curve_from_events(run["events"], seconds_end=run.get("budget_s"))


def value_at(events: list, x: float, axis: int) -> float | None:
    """The last reported reward at or before ``x`` on ``axis`` (0 = seconds, 1 = frames); None if none yet
    (past the last event: the last one, the run went on to its budget)."""
    inf = float("inf")
    return curve_from_events(events, seconds_end=inf, frames_end=inf).value_at(x, ("seconds", "frames")[axis])


def mean_std(values: list[float | None]) -> tuple[float, float] | None:
    """Mean and sample standard deviation over seeds; None unless every seed has a value."""
    if not values or any(v is None for v in values):
        return None
    return statistics.fmean(values), (statistics.stdev(values) if len(values) > 1 else 0.0)


def frame_grid(runs: dict[str, list[dict]], points: int = 4) -> list[int]:
    """Frame counts every run of every library reached: ``points`` even steps up to the smallest last frame."""
    reach = min(run["events"][-1][1] for lib_runs in runs.values() for run in lib_runs)
    step = 10 ** max(0, int(math.log10(max(reach, 1))) - 1)  # round to two significant digits
    return [int(reach * k / points) // step * step for k in range(1, points + 1)]


def time_grid(budget: float, points: int = 4) -> list[float]:
    """Times from process start at which to compare: even steps up to the budget."""
    return [round(budget * k / points) for k in range(1, points + 1)]


def fps(run: dict) -> float:
    """Frames per second from process start to the last reward event (startup included)."""
    t, frames, _ = run["events"][-1]
    return frames / max(t, 1e-9)


def judge(ours: tuple[float, float] | None, peer: tuple[float, float] | None) -> str:
    """'ahead' / 'level' / 'behind': behind or ahead only where the gap exceeds both seed spreads added."""
    if ours is None or peer is None:
        return "-"
    gap, noise = ours[0] - peer[0], ours[1] + peer[1]
    return "ahead" if gap > noise else "behind" if -gap > noise else "level"


def time_to(events: list, target: float) -> float | None:
    """Seconds from process start until the reported reward first reaches ``target``; None if never."""
    return next((t for t, _, value in events if value >= target), None)


def reach_cell(times: list[float | None], spread: bool = False) -> str:
    """Median seconds to a target over seeds (a seed that never reached it counts as later than all), and
    how many seeds reached it; with ``spread``, the fastest and slowest seed that reached it too (where they differ)."""
    reached = sorted(t for t in times if t is not None)
    median = reach_median(times)
    if median is None:
        return f"not reached ({len(reached)}/{len(times)})"
    span = f" [{reached[0]:.0f}-{reached[-1]:.0f}]" if spread and reached[0] != reached[-1] else ""
    return f"{median:.0f} s{span} ({len(reached)}/{len(times)})"


def reach_median(times: list[float | None]) -> float | None:
    """Median seconds to a target over seeds, a seed that never reached it counting as later than all;
    None when the median seed never reached it (or there are no seeds)."""
    reached = sorted(t for t in times if t is not None)
    median = statistics.median(reached + [math.inf] * (len(times) - len(reached))) if times else math.inf
    return None if math.isinf(median) else median


def sooner(peer: float | None, ours: float | None) -> str:
    """How many times sooner rlchain reached a target than a peer (the peer's median seconds over rlchain's):
    '> budget' where only rlchain reached it, '-' where rlchain did not."""
    if ours is None:
        return "-"
    if peer is None:
        return "> budget"
    return f"{peer / max(ours, 1e-9):.2f}x"


def time_to_reward(config: str, runs: dict[str, list[dict]], budget: float, target_lib: str,
                   names: list[str]) -> list[str] | None:
    """One row (its cells) of the time-to-reward table: the target is ``target_lib``'s mean reward over seeds
    at ``budget`` seconds; for each system of ``names``, its median seconds to reach it [fastest-slowest seed]
    (seeds that reached it / seeds), '-' without runs; then, if rlchain is one of them, how many times sooner
    rlchain got there than each other system. None where ``target_lib`` has no runs."""
    final = mean_std([value_at(r["events"], budget, 0) for r in runs.get(target_lib, [])])
    if final is None:
        return None
    times = {n: [time_to(r["events"], final[0]) for r in runs.get(n, [])] for n in names}
    cells = [config, f"{target_lib} at {budget:g} s: {final[0]:.0f}"]
    cells += [reach_cell(times[n], spread=True) if times[n] else "-" for n in names]
    if "rlchain" in names:
        ours = reach_median(times["rlchain"])
        cells += [sooner(reach_median(times[n]), ours) if times[n] else "-" for n in names if n != "rlchain"]
    return cells


def time_to_reward_table(rows: list[tuple[str, dict[str, list[dict]], float]]) -> list[str]:
    """Markdown lines of the headline table (time to reward): for each config (its runs and budget) and each peer
    (every system but rlchain) as the target, the seconds every system needs to reach the target's mean reward at
    the end of its budget, and how many times sooner rlchain got there. The columns are every system with runs in
    any of ``rows``."""
    names = [name for name in SYSTEMS if any(runs.get(name) for _, runs, _ in rows)]
    targets = [n for n in names if n != "rlchain"]
    others = targets if "rlchain" in names else []
    lines = ["| YAML | target: mean reward | " + " | ".join(names) + "".join(f" | {p} / rlchain" for p in others)
             + " |", "|---|---|" + "---|" * (len(names) + len(others))]
    for config, runs, budget in rows:
        for target in targets:
            cells = time_to_reward(config, runs, budget, target, names)
            if cells is not None:
                lines.append("| " + " | ".join(cells) + " |")
    return lines


def summarise(config: str, runs: dict[str, list[dict]], budget: float) -> list[str]:
    """Markdown lines: one table row per grid point, every system, rlchain's ratio and verdict against each
    peer; then the seconds each system needs to reach each peer's mean reward at the end of its budget."""
    names = [name for name in SYSTEMS if runs.get(name)]
    peers = [name for name in names if name != "rlchain" and runs.get("rlchain")]
    seeds = {name: len(runs[name]) for name in names}
    lines = [f"### {config} ({budget:g} s each)", ""]
    lines += [f"- `{name}`: {describe(name)}, {seeds[name]} seeds" for name in names] + [""]
    lines += ["| at | " + " | ".join(names) + "".join(f" | rlchain / {p}" for p in peers) + " |",
              "|---|" + "---|" * (len(names) + len(peers))]

    def row(label: str, stats: dict, verdict: bool = True) -> str:
        cells = [f"{s[0]:.0f} +- {s[1]:.0f}" if s else "-" for s in (stats[name] for name in names)]
        ours = stats.get("rlchain")
        for peer in peers:
            theirs = stats.get(peer)
            ratio = f"{ours[0] / theirs[0]:.2f}x" if ours and theirs and theirs[0] > 0 else "-"
            cells.append(f"{ratio} {judge(ours, theirs)}" if verdict else ratio)
        return f"| {label} | " + " | ".join(cells) + " |"

    if len(names) > 1:
        for frames in frame_grid({name: runs[name] for name in names}):
            stats = {n: mean_std([value_at(r["events"], frames, 1) for r in runs[n]]) for n in names}
            lines.append(row(f"{frames / 1e6:.2f}M frames", stats))
    for seconds in time_grid(budget):
        stats = {n: mean_std([value_at(r["events"], seconds, 0) for r in runs[n]]) for n in names}
        lines.append(row(f"{seconds:.0f} s", stats))
    lines.append(row("frames/s", {n: mean_std([fps(r) for r in runs[n]]) for n in names}, verdict=False))
    if peers:
        lines += ["", "Seconds from process start to reach each peer's mean reward at the end of its budget (median "
                      "over seeds, a seed that never reached it counting as later than all [fastest-slowest seed "
                      "that reached it] (seeds that reached it / seeds)):", ""]
        lines += time_to_reward_table([(config, runs, budget)])
    return lines


# ----- plotting ------------------------------------------------------------------------------------
def as_groups(runs: dict[str, list[dict]]) -> dict[str, list[Run]]:
    """The saved runs as rlchain.compare groups, labelled as the tables and legends name the systems."""
    return {describe(lib): [Run(f"{lib}_seed{r['seed']}", describe(lib), r["config"], {REWARD: curve(r)})
                            for r in lib_runs] for lib, lib_runs in runs.items() if lib_runs}


def band(runs: list[dict], axis: int, xs: list[float]) -> tuple[list[float], list[float], list[float], list[float]]:
    """Mean, min and max over seeds at each x where every seed has a value (benchmarks/peers/her_vs_sb3.py's plots)."""
    out: tuple[list[float], list[float], list[float], list[float]] = ([], [], [], [])
    for x in xs:
        values = [value_at(r["events"], x, axis) for r in runs]
        if all(v is not None for v in values):
            for series, v in zip(out, (x, statistics.fmean(values), min(values), max(values))):
                series.append(v)
    return out


def plot(config: str, runs: dict[str, list[dict]], budget: float, path: str) -> None:
    """reward vs frames and reward vs seconds, mean line and min-max seed band per system (rlchain.compare's
    plot; the frames axis ends at the last frame count every seed of the system reached)."""
    groups = as_groups(runs)
    colors = {describe(lib): COLORS.get(lib) for lib in runs}
    plot_tag(groups, REWARD, path, f"{os.path.basename(CONFIGS[config])}: mean and min-max over seeds",
             band="minmax", colors=colors, ylabel="mean episode reward", legend_loc="lower right",
             xlabels={"frames": "frames", "seconds": "seconds from process start"})


def iqm_table(config: str, runs: dict[str, list[dict]], budget: float) -> list[str]:
    """Markdown lines: IQM over seeds [95% stratified bootstrap interval] of each system at the table's frame
    and time points (rlchain compare's table, on the saved runs)."""
    groups = as_groups(runs)
    settings = Settings("iqm", 0.95, 2000, 0)
    lines = ["IQM over seeds [95% bootstrap interval, 2000 resamples, seed 0] (`rlchain compare`'s statistics; "
             "seeds that reached the point / seeds):", ""]
    if len(groups) > 1:
        lines += table(groups, REWARD, "frames", frame_grid(runs), settings) + [""]
    lines += table(groups, REWARD, "seconds", time_grid(budget), settings)
    return lines


def splice(document: str, text: str, begin: str = "<!-- curves:begin -->", end: str = "<!-- curves:end -->") -> str:
    """``document`` with everything between the ``begin`` and ``end`` markers replaced by ``text``."""
    head, found, rest = document.partition(begin)
    _, found_end, tail = rest.partition(end)
    if not found or not found_end:
        raise ValueError(f"markers {begin} ... {end} not found")
    return f"{head}{begin}\n{text}\n{end}{tail}"


# ----- command line --------------------------------------------------------------------------------
def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--configs", nargs="+", choices=sorted(CONFIGS), default=list(CONFIGS))
    p.add_argument("--seeds", nargs="+", type=int, default=list(DEFAULT_SEEDS))
    p.add_argument("--seconds", type=float, default=300.0, help="wall-clock budget of each run")
    p.add_argument("--frames", type=int, default=None,
                   help="also stop each run after this many env frames (per-frame comparisons on a loaded machine)")
    p.add_argument("--pendulum-seconds", type=float, default=150.0,
                   help="budget of ppo_pendulum_torch runs (rl_games starts 16 Ray actors for it: ~60 s on 2 cores)")
    p.add_argument("--tensor-seconds", type=float, default=30.0,
                   help="budget of the tensor-env runs (" + ", ".join(TENSOR_CONFIGS) + ")")
    p.add_argument("--libs", nargs="+", choices=list(SYSTEMS), default=["rlchain", "rl_games", "rl_games2"],
                   help="systems to run: " + "; ".join(f"{n}: {describe(n)}" for n in SYSTEMS))
    p.add_argument("--rl-games-python", default="/work/rlg-venv/bin/python", help="rl_games 1.6.5's venv")
    p.add_argument("--rl-games2-python", default="/work/rlg2-venv/bin/python",
                   help="rl_games' main branch (2.0) built from source (benchmarks/README.md)")
    p.add_argument("--rlchain-python", default=sys.executable)
    p.add_argument("--rlchain-args", default="", help="extra runner.py arguments, e.g. key=value overrides")
    p.add_argument("--rl-games-args", default="", help="extra rl_games_driver.py arguments")
    p.add_argument("--out", default=None, help="runs/, results.md and the PNGs go here (default: benchmarks/results/"
                                              "curves, outside git)")
    p.add_argument("--runs", default=None, help="folder of the saved runs (default OUT/runs): e.g. an earlier "
                                               "--out's runs with --plot-only and more seeds into another --out")
    p.add_argument("--docs-prefix", default=None,
                   help="also copy each PNG to docs/img/PREFIX_<config>.png, the plots the Benchmarks page shows")
    p.add_argument("--rerun", action="store_true", help="train again even where a saved run exists")
    p.add_argument("--plot-only", action="store_true", help="no training: table and plots from the saved runs")
    args = p.parse_args(argv)
    if args.out is None:
        args.out = results_dir("curves")
    if args.frames is not None and args.frames <= 0:
        p.error(f"--frames must be a positive number of env frames, got {args.frames}")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    runs_dir = args.runs or os.path.join(args.out, "runs")
    cpu = cpu_model()
    for seed in args.seeds:  # seed-major (a cut-short run still has whole seeds), libraries alternating
        for config in args.configs:
            budget = budget_of(config, args)
            for lib in args.libs:
                path = run_path(runs_dir, config, lib, seed)
                saved = load_runs(runs_dir, config, [lib], [seed], budget, args.frames)[lib]
                if args.plot_only or (not args.rerun and saved):
                    continue
                try:
                    run = train_for(lib, config, seed, budget, args)
                except RuntimeError as exc:  # no reward reported in the budget: said, not saved
                    print(exc, file=sys.stderr, flush=True)
                    continue
                run["cpu"] = cpu
                os.makedirs(os.path.dirname(path), exist_ok=True)
                with open(path, "w") as f:
                    json.dump(run, f)
    os.makedirs(args.out, exist_ok=True)
    lines = [f"CPU: {cpu}; one run at a time; budgets from process start (startup included).", ""]
    skipped: list[str] = []
    every = [(config, load_runs(runs_dir, config, args.libs, args.seeds, budget, args.frames, skipped), budget)
             for config, budget in ((c, budget_of(c, args)) for c in args.configs)]
    for line in skipped:  # e.g. --plot-only without the runs' --seconds: say so rather than plot nothing
        print(f"curves.py: not used: {line}", file=sys.stderr)
    headline = [row for row in every if sum(map(bool, row[1].values())) > 1]
    if headline:
        lines += ["### Time to reward", "",
                  "Seconds from process start until a run's reported mean reward first reaches the target, the "
                  "target system's mean over seeds at the end of its budget: median over seeds (a seed that never "
                  "reached it counts as later than all) [fastest-slowest seed that reached it] (seeds that reached "
                  "it / seeds); `peer / rlchain` is how many times sooner rlchain got there.", ""]
        lines += time_to_reward_table(headline) + [""]
    for config, runs, budget in every:
        if not any(runs.values()):
            continue
        loads = [r[k] for lib_runs in runs.values() for r in lib_runs for k in ("load_before", "load_after")]
        lines += summarise(config, runs, budget)
        lines += [""] + iqm_table(config, runs, budget)
        lines += ["", f"load average (1 min) before/after the runs: {min(loads):.2f}-{max(loads):.2f}; "
                      f"![{config}]({config}.png)", ""]
        plot(config, runs, budget, os.path.join(args.out, f"{config}.png"))
    text = "\n".join(lines)
    print(text)
    with open(os.path.join(args.out, "results.md"), "w") as f:
        f.write(text + "\n")
    if args.docs_prefix:  # MkDocs serves only docs/: the Benchmarks page shows these copies
        for name in sorted(os.listdir(args.out)):
            if name.endswith(".png"):
                shutil.copyfile(os.path.join(args.out, name), os.path.join(DOCS_IMG, f"{args.docs_prefix}_{name}"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
