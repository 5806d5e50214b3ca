"""SAC + hindsight replay, rlchain against Stable-Baselines3: success rate against frames and seconds.

For one rlchain SAC+HER YAML (envpool ``FetchReach-v4`` / ``FetchPush-v4``), each seed and each library,
one training run for the same frame budget, one process at a time: rlchain trains the YAML with
``runner.py --train``; SB3 trains SAC + HerReplayBuffer on the same envpool task with the same
hyperparameters where SB3 has them (``sb3_her_driver.py`` reads the same YAML copy). Each run gets a
copy of the YAML with ``params.seed`` / ``env_config.seed`` set to the seed, ``max_frames`` set to the
budget and ``success_to_win`` off (both libraries train the whole budget); nothing else changes. Both
write ``episodes/success_rate`` and ``rewards/step`` against frames to TensorBoard; their events (wall
time from process start, frames, value) are saved as JSON under ``--out``, and from them the script
writes

* a table of mean +- standard deviation over seeds of the success rate at fixed frame counts and at
  fixed seconds from process start, the frames and seconds to a success rate of ``--target``,
  frames/s, and the ratio rlchain / SB3 (``results.md``, also printed);
* a PNG with success vs frames and success vs seconds, both libraries, the min-max seed band shaded.

Every results file records the CPU model, the load average before and after each run and the
versions. Runs already saved with the same budget are reused (``--rerun`` trains them again);
``--plot-only`` regenerates the table and the PNG. ``--out`` defaults to benchmarks/results/her_vs_sb3 (outside
git); with ``--docs`` the table and the PNG also go into docs/robot_learning.md (between
``<!-- her_vs_sb3_<task>:begin -->`` and ``:end -->`` markers) and docs/img/. Example (FetchReach, 3 seeds of
10k frames)::

    nice -n 10 python benchmarks/peers/her_vs_sb3.py --task reach
    nice -n 10 python benchmarks/peers/her_vs_sb3.py --task push --seeds 0 --max-frames 8000

Needs matplotlib in the interpreter that runs this script (``pip install -e ".[bench]"``) and
stable-baselines3 in ``--sb3-python``'s venv (benchmarks/README.md, "Installing the peers").
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

import yaml

if __package__ in (None, ""):  # run by path: this checkout's benchmarks and rlchain first
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from benchmarks.common import DOCS_IMG, REPO, cpu_model, results_dir  # noqa: E402
from benchmarks.peers.compare import read_rewards, stop  # noqa: E402
from benchmarks.peers.curves import band, fps, frame_grid, judge, mean_std, splice, time_grid, value_at  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
TASKS = {"reach": "rlchain/configs/sac_her_fetch_reach.yaml", "push": "rlchain/configs/sac_her_fetch_push.yaml"}
LIBS = ("rlchain", "sb3")
COLORS = {"rlchain": "tab:blue", "sb3": "tab:green"}
SUCCESS, REWARD = "episodes/success_rate", "rewards/step"


# ----- running -------------------------------------------------------------------------------
def run_config(path: str, seed: int, max_frames: int | None, workdir: str) -> str:
    """A copy of the YAML in ``workdir``: seeds set, ``max_frames`` set (if given), success_to_win off."""
    with open(path) as f:
        cfg = yaml.safe_load(f)
    cfg["params"]["seed"] = seed
    config = cfg["params"]["config"]
    config.setdefault("env_config", {})["seed"] = seed
    if max_frames:
        config["max_frames"] = max_frames
    config.pop("success_to_win", None)  # both libraries train the whole budget
    out = os.path.join(workdir, os.path.basename(path))
    with open(out, "w") as f:
        yaml.safe_dump(cfg, f, sort_keys=False)
    return out


def command(lib: str, cfg_path: str, args: argparse.Namespace) -> list[str]:
    """The training command of one library."""
    if lib == "rlchain":
        return [args.rlchain_python, os.path.join(REPO, "runner.py"), "--train", "--file", cfg_path,
                *shlex.split(args.rlchain_args)]
    return [args.sb3_python, os.path.join(HERE, "sb3_her_driver.py"), "--file", cfg_path,
            *shlex.split(args.sb3_args)]


def uptime() -> str:
    """``uptime``'s line (the load of the machine, which other jobs share)."""
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "load average: " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def train(lib: str, task: str, seed: int, args: argparse.Namespace) -> dict:
    """One run to its frame budget (or ``--max-seconds``); its events and conditions."""
    workdir = tempfile.mkdtemp(prefix=f"her_{task}_{lib}_{seed}_")
    cfg_path = run_config(os.path.join(REPO, args.file or TASKS[task]), seed, args.max_frames, workdir)
    cmd = command(lib, cfg_path, args)
    print(f"[{task} {lib} seed {seed}] $ {shlex.join(cmd)}", flush=True)
    before, load_before = uptime(), os.getloadavg()[0]
    with open(os.path.join(workdir, "train.log"), "wb") as log:
        t0 = time.time()
        proc = subprocess.Popen(cmd, cwd=workdir, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                start_new_session=True)
        try:
            while proc.poll() is None and time.time() - t0 < args.max_seconds:
                time.sleep(1.0)
        finally:
            stop(proc)
    wall = time.time() - t0
    events = {tag: [(w - t0, step, value) for w, step, value in read_rewards(workdir, {}, tag)]
              for tag in (SUCCESS, REWARD)}
    if not events[SUCCESS]:
        with open(os.path.join(workdir, "train.log"), "rb") as f:
            tail = f.read()[-2000:].decode(errors="replace")
        raise RuntimeError(f"[{task} {lib} seed {seed}] no {SUCCESS} events (rc {proc.returncode}); "
                           f"log in {workdir}:\n{tail}")
    last = events[SUCCESS][-1]
    print(f"[{task} {lib} seed {seed}] {last[1]} frames, success {last[2]:.2f} at {last[0]:.0f} s", flush=True)
    return {"task": task, "lib": lib, "seed": seed, "max_frames": args.max_frames, "wall_s": wall,
            "events": events[SUCCESS], "reward_events": events[REWARD], "load_before": load_before,
            "load_after": os.getloadavg()[0], "uptime_before": before, "uptime_after": uptime(), "cmd": cmd,
            "returncode": proc.returncode, "date": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())}


def run_path(out: str, task: str, lib: str, seed: int) -> str:
    return os.path.join(out, "events", task, f"{lib}_seed{seed}.json")  # tracked (runs/ is git-ignored)


def load_runs(out: str, task: str, seeds: list[int], max_frames: int | None) -> dict[str, list[dict]]:
    """The saved runs of ``task`` with this frame budget, by library."""
    runs: dict[str, list[dict]] = {lib: [] for lib in LIBS}
    for lib in LIBS:
        for seed in seeds:
            path = run_path(out, task, lib, seed)
            if os.path.exists(path):
                with open(path) as f:
                    run = json.load(f)
                if run["max_frames"] == max_frames:
                    runs[lib].append(run)
    return runs


# ----- summarising (pure functions) -------------------------------------------------------------
def first_reach(events: list, target: float) -> tuple[float, int] | None:
    """(seconds, frames) of the first report >= ``target``; None if the run never got there."""
    for t, frames, value in events:
        if value >= target:
            return t, frames
    return None


def summarise(task: str, runs: dict[str, list[dict]], target: float, points: int = 5) -> list[str]:
    """Markdown lines: success at ``points`` fixed frames and seconds, frames / seconds to ``target``,
    seconds to the first report (startup and warmup), frames/s."""
    libs = [lib for lib in LIBS if runs.get(lib)]
    seeds = sorted({r["seed"] for lib in libs for r in runs[lib]})
    lines = [f"| {task}: seeds {', '.join(map(str, seeds))} | " + " | ".join(libs) + " | rlchain / sb3 | verdict |",
             "|---|" + "---|" * (len(libs) + 2)]

    def row(label: str, stats: dict, fmt: str, verdict: bool = True) -> str:
        cells = [(fmt.format(*s) if s else "-") for s in (stats[lib] for lib in libs)]
        ours, peer = stats.get("rlchain"), stats.get("sb3")
        ratio = f"{ours[0] / peer[0]:.2f}x" if ours and peer and peer[0] > 0 else "-"
        return f"| {label} | " + " | ".join(cells) + f" | {ratio} | {judge(ours, peer) if verdict else ''} |"

    success = "{:.2f} +- {:.2f}"
    if len(libs) == 2:
        for frames in frame_grid(runs, points):
            stats = {lib: mean_std([value_at(r["events"], frames, 1) for r in runs[lib]]) for lib in libs}
            lines.append(row(f"success at {frames} frames", stats, success))
    shortest = min(r["events"][-1][0] for lib in libs for r in runs[lib])
    for seconds in time_grid(shortest, points):
        stats = {lib: mean_std([value_at(r["events"], seconds, 0) for r in runs[lib]]) for lib in libs}
        lines.append(row(f"success at {seconds:.0f} s", stats, success))
    for axis, label in ((1, "frames"), (0, "seconds")):
        reached = {lib: [first_reach(r["events"], target) for r in runs[lib]] for lib in libs}
        stats = {lib: mean_std([x[axis] if x else None for x in reached[lib]]) for lib in libs}
        counts = {lib: sum(x is not None for x in reached[lib]) for lib in libs}
        note = ", ".join(f"{lib} {counts[lib]}/{len(runs[lib])}" for lib in libs)
        lines.append(row(f"{label} to success {target:g} (seeds there: {note})", stats, "{:.0f} +- {:.0f}",
                         verdict=False))
    first = {lib: mean_std([r["events"][0][0] for r in runs[lib]]) for lib in libs}
    lines.append(row("seconds to the first report (one epoch)", first, "{:.1f} +- {:.1f}", verdict=False))
    rates = {lib: mean_std([fps(r) for r in runs[lib]]) for lib in libs}
    lines.append(row("frames/s (from process start)", rates, "{:.1f} +- {:.1f}", verdict=False))
    return lines


# ----- plotting ------------------------------------------------------------------------------------
def plot(task: str, runs: dict[str, list[dict]], path: str, title: str) -> None:
    """Success vs frames and success vs seconds: mean line and min-max seed band per library
    (``curves.band``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for lib, lib_runs in runs.items():
        if not lib_runs:
            continue
        max_frames = max(r["events"][-1][1] for r in lib_runs)
        max_seconds = max(r["events"][-1][0] for r in lib_runs)
        for ax, axis, last in ((axes[0], 1, max_frames), (axes[1], 0, max_seconds)):
            x, mean, low, high = band(lib_runs, axis, [last * k / 200 for k in range(201)])
            ax.plot(x, mean, color=COLORS[lib], label=f"{lib} ({len(lib_runs)} seeds)")
            ax.fill_between(x, low, high, color=COLORS[lib], alpha=0.2)
    axes[0].set_xlabel("frames")
    axes[1].set_xlabel("seconds from process start")
    for ax in axes:
        ax.set_ylabel("success rate (last tracked episodes)")
        ax.set_ylim(-0.03, 1.03)
        ax.grid(alpha=0.3)
        ax.legend(loc="best")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


# ----- command line --------------------------------------------------------------------------------
def versions(args: argparse.Namespace) -> str:
    """torch / SB3 / envpool / gymnasium versions of both interpreters."""
    code = ("import importlib.metadata as m\n"
            "for p in ('torch', 'stable-baselines3', 'envpool', 'gymnasium'):\n"
            "    try: print(p, m.version(p))\n"
            "    except m.PackageNotFoundError: pass")
    out = []
    for lib, python in (("rlchain", args.rlchain_python), ("sb3", args.sb3_python)):
        try:
            text = subprocess.run([python, "-c", code], capture_output=True, text=True, timeout=120).stdout
            text = ", ".join(text.split("\n")[:-1]) or "?"
        except (OSError, subprocess.TimeoutExpired):
            text = "?"
        out.append(f"{lib}: {text}")
    return "; ".join(out)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--task", choices=sorted(TASKS), default="reach")
    p.add_argument("--file", default=None, help="another rlchain SAC+HER YAML (default: the task's)")
    p.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    p.add_argument("--max-frames", type=int, default=None, help="frame budget of every run (default: the YAML's)")
    p.add_argument("--max-seconds", type=float, default=900.0, help="stop a run after this long anyway")
    p.add_argument("--target", type=float, default=0.8, help="success rate whose frames / seconds are reported")
    p.add_argument("--libs", nargs="+", choices=LIBS, default=list(LIBS))
    p.add_argument("--sb3-python", default="/work/rlg-venv/bin/python")
    p.add_argument("--rlchain-python", default=sys.executable)
    p.add_argument("--rlchain-args", default="", help="extra runner.py arguments, e.g. key=value overrides")
    p.add_argument("--sb3-args", default="--torch-threads 1",
                   help="extra sb3_her_driver.py arguments (default: one torch thread, what rlchain's own thread "
                        "rule picks on a 2-core machine; torch's default of one per core oversubscribes a busy one)")
    p.add_argument("--out", default=None,
                   help="events/ (the saved runs), results and PNGs go here (default: benchmarks/results/her_vs_sb3)")
    p.add_argument("--docs", action="store_true",
                   help="also splice the table into docs/robot_learning.md and copy the PNG to docs/img/")
    p.add_argument("--rerun", action="store_true", help="train again even where a saved run exists")
    p.add_argument("--plot-only", action="store_true", help="no training: table and plots from the saved runs")
    args = p.parse_args(argv)
    if args.out is None:
        args.out = results_dir("her_vs_sb3")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    cpu, task = cpu_model(), args.task
    for seed in args.seeds:  # seed-major, libraries alternating: a cut-short benchmark still has whole seeds
        for lib in args.libs:
            path = run_path(args.out, task, lib, seed)
            if args.plot_only or (not args.rerun and load_runs(args.out, task, [seed], args.max_frames)[lib]):
                continue
            try:
                run = train(lib, task, seed, args)
            except RuntimeError as exc:  # nothing reported: said, not saved
                print(exc, file=sys.stderr, flush=True)
                continue
            run["cpu"] = cpu
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "w") as f:
                json.dump(run, f)
    runs = load_runs(args.out, task, args.seeds, args.max_frames)
    runs = {lib: lib_runs for lib, lib_runs in runs.items() if lib in args.libs and lib_runs}
    if not runs:
        print("no saved runs", file=sys.stderr)
        return 1
    every = [r for lib_runs in runs.values() for r in lib_runs]
    budget = max(r["events"][-1][1] for r in every)
    png = f"her_vs_sb3_{task}.png"
    loads = ", ".join(f"{r['lib']} {r['seed']}: {r['load_before']:.1f} -> {r['load_after']:.1f}" for r in every)
    lines = [f"CPU: {cpu}; {budget} frames per run, one run at a time (`nice -n 10`), times from process start.",
             f"Versions: {versions(args)}. Runs: {min(r['date'] for r in every)} to {max(r['date'] for r in every)}.",
             "",
             *summarise(task, runs, args.target), "",
             f"Load average (1 min) before -> after each run: {loads}.", "",
             f"![SAC+HER {task}: rlchain vs SB3]({png})", ""]
    text = "\n".join(lines)
    print(text)
    os.makedirs(args.out, exist_ok=True)
    yaml_path = os.path.join(REPO, args.file or TASKS[task])
    with open(yaml_path) as f:
        env_name = yaml.safe_load(f)["params"]["config"]["env_config"]["env_name"]
    plot(task, runs, os.path.join(args.out, png), f"SAC + HER on envpool {env_name} "
         f"({os.path.basename(yaml_path)}), {budget} frames: mean and min-max over seeds")
    with open(os.path.join(args.out, f"results_{task}.md"), "w") as f:
        f.write(text + "\n")
    if args.docs:  # the results the docs show: the table into the page, the PNG beside its other images
        begin, end = f"<!-- her_vs_sb3_{task}:begin -->", f"<!-- her_vs_sb3_{task}:end -->"
        doc = os.path.join(REPO, "docs", "robot_learning.md")
        with open(doc) as f:
            document = f.read()
        if begin in document:
            with open(doc, "w") as f:
                f.write(splice(document, text.replace(f"]({png})", f"](img/{png})"), begin, end))
        shutil.copyfile(os.path.join(args.out, png), os.path.join(DOCS_IMG, png))
    return 0


if __name__ == "__main__":
    sys.exit(main())
