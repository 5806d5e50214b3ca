"""rlchain against rsl_rl (mjlab's own training) and rl_games 2.0 on one mjlab task: reward against frames and
seconds, and the seconds each system takes to reach each peer's final reward.

One rl_games 2.0 mjlab YAML gives the task (``env_config.task_name``), the seed and the batch geometry. Every
system trains the same task with the same seed, device, env count and number of epochs (rsl_rl: iterations),
one after the other:

* ``rlchain``: ``runner.py --train`` on the YAML (``cuda_graph`` as the YAML or ``--cuda-graph`` says; the
  system ``rlchain_graph_off`` / ``rlchain_graph_on`` forces it);
* ``rl_games2``: rl_games 2.0's own ``runner.py`` from a source checkout (``--rl-games-src``) on a copy of the
  YAML with the seed, device, env count, minibatch and epochs written in;
* ``rsl_rl``: ``python -m mjlab.scripts.train <task>``, mjlab's training with its shipped rsl_rl runner config
  for the task (its own network, learning rate and horizon), the env count, iterations and seed set.

With fewer envs than the YAML's, the minibatches keep their count (minibatch_size scales with num_actors). Each
run's TensorBoard mean episode reward is read back (rlchain / rl_games: ``rewards/step`` against frames;
rsl_rl: ``Train/mean_reward`` against iterations, x num_steps_per_env x num_envs frames) with its wall times, and
``--out`` gets ``runs.json`` (every point), ``summary.md`` (final reward, frames, seconds, frames/s, and the
seconds to each peer's final reward) and ``curves.png`` (matplotlib, when installed).

Run it with a Python that has mjlab (and rl_games 2.0's dependencies, tensorboardX, for rl_games2). On a GPU::

    python benchmarks/peers/mjlab_peers.py --config rlchain/configs/rl_games/ppo_go1_velocity.yaml --device cuda:0 \\
        --envs 4096 --epochs 300 --rl-games-src /path/to/rl_games --out /tmp/mjlab_go1
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time

import yaml

if __package__ in (None, ""):  # run by path: this checkout's benchmarks and rlchain first
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from benchmarks.common import REPO, results_dir  # noqa: E402

SYSTEMS = ("rlchain", "rlchain_graph_off", "rlchain_graph_on", "rsl_rl", "rl_games2")
RLCHAIN_REWARD, RSL_REWARD = "rewards/step", "Train/mean_reward"


def load_yaml(path: str) -> dict:
    with open(path, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def geometry(config: dict, envs: int) -> dict:
    """num_actors, horizon and minibatch sizes for ``envs`` envs, keeping the YAML's number of minibatches."""
    cfg = config["params"]["config"]
    horizon = int(cfg["horizon_length"])
    batch = int(cfg["num_actors"]) * horizon

    def scaled(minibatch: int) -> int:
        count = max(1, round(batch / int(minibatch)))
        return max(1, envs * horizon // count)

    out = {"num_actors": envs, "horizon_length": horizon, "minibatch_size": scaled(cfg["minibatch_size"])}
    cv = cfg.get("central_value_config")
    if cv and cv.get("minibatch_size"):
        out["cv_minibatch_size"] = scaled(cv["minibatch_size"])
    return out


def rlchain_command(args: argparse.Namespace, shape: dict, run_dir: str, graph: str | None) -> list[str]:
    overrides = [f"params.config.device={args.device}", f"params.config.env_config.device={args.device}",
                 f"params.config.num_actors={shape['num_actors']}",
                 f"params.config.minibatch_size={shape['minibatch_size']}",
                 f"params.config.max_epochs={args.epochs}", f"params.config.train_dir={run_dir}",
                 "params.config.save_frequency=0"]
    if "cv_minibatch_size" in shape:
        overrides.append(f"params.config.central_value_config.minibatch_size={shape['cv_minibatch_size']}")
    if graph is not None:
        overrides.append(f"params.config.cuda_graph={graph}")
    return [args.python, os.path.join(REPO, "runner.py"), "--train", "--file", args.config, "--seed",
            str(args.seed), *overrides]


def rl_games_command(args: argparse.Namespace, config: dict, shape: dict, run_dir: str) -> list[str]:
    config = json.loads(json.dumps(config))
    config["params"]["seed"] = args.seed
    cfg = config["params"]["config"]
    cfg.update(device=args.device, num_actors=shape["num_actors"], minibatch_size=shape["minibatch_size"],
               max_epochs=args.epochs, train_dir=run_dir, save_frequency=0)
    cfg["env_config"]["device"] = args.device
    if "cv_minibatch_size" in shape:
        cfg["central_value_config"]["minibatch_size"] = shape["cv_minibatch_size"]
    path = os.path.join(run_dir, "config.yaml")
    os.makedirs(run_dir, exist_ok=True)
    with open(path, "w", encoding="utf-8") as fh:
        yaml.safe_dump(config, fh)
    return [args.python, os.path.join(args.rl_games_src, "runner.py"), "--train", "--file", path]


def rsl_rl_command(args: argparse.Namespace, task: str, shape: dict, run_dir: str) -> list[str]:
    gpus = "None" if args.device == "cpu" else str(int(args.device.split(":")[1]) if ":" in args.device else 0)
    return [args.python, "-m", "mjlab.scripts.train", task, "--env.scene.num-envs", str(shape["num_actors"]),
            "--agent.max-iterations", str(args.epochs), "--agent.seed", str(args.seed), "--agent.save-interval",
            str(10 ** 9), "--agent.logger", "tensorboard", "--log-root", run_dir, "--gpu-ids", gpus]


def scalar_events(folder: str, tag: str) -> list[tuple[float, int, float]]:
    """(wall time, step, value) of ``tag`` in the TensorBoard event files under ``folder``."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = []
    for path in sorted(glob.glob(os.path.join(folder, "**", "events.out.tfevents.*"), recursive=True)):
        acc = EventAccumulator(path, size_guidance={"scalars": 0})
        acc.Reload()
        if tag in acc.Tags()["scalars"]:
            events += [(e.wall_time, int(e.step), float(e.value)) for e in acc.Scalars(tag)]
    return sorted(events)


def rsl_rl_frames_per_iteration(run_dir: str, envs: int) -> int:
    """num_steps_per_env (mjlab's params/agent.yaml) x envs."""
    for path in glob.glob(os.path.join(run_dir, "**", "params", "agent.yaml"), recursive=True):
        with open(path, encoding="utf-8") as fh:
            agent = yaml.unsafe_load(fh)
        return int(agent["num_steps_per_env"]) * envs
    raise FileNotFoundError(f"no params/agent.yaml under {run_dir}: the rsl_rl run did not start")


def points(system: str, run_dir: str, envs: int, started: float) -> list[tuple[float, int, float]]:
    """(seconds since the process started, frames, mean reward) of one run."""
    if system == "rsl_rl":
        per_iteration = rsl_rl_frames_per_iteration(run_dir, envs)
        raw = [(w, (step + 1) * per_iteration, v) for w, step, v in scalar_events(run_dir, RSL_REWARD)]
    else:
        raw = scalar_events(run_dir, RLCHAIN_REWARD)
    return [(w - started, frames, v) for w, frames, v in raw if math.isfinite(v)]


def train(system: str, args: argparse.Namespace, config: dict, shape: dict, work: str) -> dict:
    run_dir = os.path.join(work, system)
    shutil.rmtree(run_dir, ignore_errors=True)
    os.makedirs(run_dir)
    env = dict(os.environ)
    if system == "rl_games2":
        env["PYTHONPATH"] = os.pathsep.join([args.rl_games_src, env.get("PYTHONPATH", "")])
        command = rl_games_command(args, config, shape, run_dir)
    elif system == "rsl_rl":
        if args.device == "cpu":
            env["CUDA_VISIBLE_DEVICES"] = ""
        command = rsl_rl_command(args, config["params"]["config"]["env_config"]["task_name"], shape, run_dir)
    else:
        graph = {"rlchain_graph_off": "False", "rlchain_graph_on": "True"}.get(system)
        command = rlchain_command(args, shape, run_dir, graph)
    started = time.time()
    with open(os.path.join(work, f"{system}.log"), "w", encoding="utf-8") as log:
        process = subprocess.Popen(command, cwd=run_dir, env=env, stdout=log, stderr=subprocess.STDOUT)
        try:
            code = process.wait(timeout=args.timeout)
        except subprocess.TimeoutExpired:  # cut at its time budget: the points it logged so far still count
            process.send_signal(signal.SIGINT)  # a KeyboardInterrupt lets its log writers flush
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
            code = 124
    seconds = time.time() - started
    got = points(system, run_dir, shape["num_actors"], started) if code in (0, 124) else []
    return {"system": system, "returncode": code, "seconds": seconds, "points": got, "command": command}


def time_to(run: dict, target: float) -> float | None:
    """Seconds until the run's reward first reaches ``target`` (None: never)."""
    return next((s for s, _, v in run["points"] if v >= target), None)


def final(run: dict) -> float | None:
    return run["points"][-1][2] if run["points"] else None


def summary(runs: list[dict], args: argparse.Namespace) -> str:
    task = load_yaml(args.config)["params"]["config"]["env_config"]["task_name"]
    lines = [f"# {task}: {os.path.basename(args.config)}, seed {args.seed}, device {args.device}, "
             f"{args.envs} envs, {args.epochs} epochs", "",
             "| system | final reward | frames | seconds | frames/s | exit |", "|---|---|---|---|---|---|"]
    for run in runs:
        last = run["points"][-1] if run["points"] else None
        fps = f"{last[1] / run['seconds']:.0f}" if last else "-"
        lines.append(f"| {run['system']} | {'-' if last is None else f'{last[2]:.2f}'} | "
                     f"{'-' if last is None else last[1]} | {run['seconds']:.1f} | {fps} | {run['returncode']} |")
    lines += ["", "Seconds to reach each peer's final reward (rows: who trains; columns: whose final reward):", "",
              "| system | " + " | ".join(r["system"] for r in runs) + " |", "|---|" + "---|" * len(runs)]
    for run in runs:
        cells = []
        for peer in runs:
            target = final(peer)
            reached = None if target is None else time_to(run, target)
            cells.append("-" if reached is None else f"{reached:.1f}")
        lines.append(f"| {run['system']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def plot(runs: list[dict], path: str, title: str) -> bool:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for run in runs:
        if run["points"]:
            seconds, frames, values = zip(*run["points"])
            axes[0].plot(frames, values, label=run["system"])
            axes[1].plot(seconds, values, label=run["system"])
    for ax, xlabel in zip(axes, ("env frames", "seconds")):
        ax.set_xlabel(xlabel)
        ax.set_ylabel("mean episode reward")
        ax.legend()
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return True


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--config", required=True, help="an rl_games 2.0 mjlab YAML (env_config.task_name: the task)")
    p.add_argument("--systems", default="rlchain,rsl_rl,rl_games2",
                   help=f"comma-separated, in run order, from {', '.join(SYSTEMS)}")
    p.add_argument("--seed", type=int, default=42)
    p.add_argument("--device", default="cpu", help="cpu or cuda:N, for the env and the training")
    p.add_argument("--envs", type=int, default=16, help="num_actors / --env.scene.num-envs")
    p.add_argument("--epochs", type=int, default=3, help="max_epochs / --agent.max-iterations")
    p.add_argument("--rl-games-src", default=os.environ.get("RL_GAMES_SRC", ""),
                   help="an rl_games 2.0 (main branch) source checkout, for rl_games2")
    p.add_argument("--python", default=sys.executable, help="the interpreter every system runs under")
    p.add_argument("--timeout", type=float, default=3600.0,
                   help="seconds per run; a run cut there keeps the rewards it logged (exit 124 in the summary)")
    p.add_argument("--out", default=None, help="results folder (default: benchmarks/results/mjlab_peers/<time>)")
    args = p.parse_args(argv)
    args.systems = [s.strip() for s in args.systems.split(",") if s.strip()]
    unknown = [s for s in args.systems if s not in SYSTEMS]
    if unknown:
        p.error(f"--systems: unknown {', '.join(unknown)} (valid: {', '.join(SYSTEMS)})")
    if "rl_games2" in args.systems and not os.path.isfile(os.path.join(args.rl_games_src, "runner.py")):
        p.error("--rl-games-src: needs an rl_games 2.0 source checkout (its runner.py) for rl_games2")
    if args.envs < 1 or args.epochs < 1:
        p.error("--envs and --epochs take integers >= 1")
    args.config = os.path.abspath(args.config)
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    config = load_yaml(args.config)
    shape = geometry(config, args.envs)
    out = args.out or results_dir("mjlab_peers", time.strftime("%Y%m%d-%H%M%S"))
    os.makedirs(out, exist_ok=True)
    runs = []
    for system in args.systems:
        print(f"training {system} ...", flush=True)
        runs.append(train(system, args, config, shape, os.path.join(out, "runs")))
        last = runs[-1]
        print(f"  {system}: exit {last['returncode']}, {last['seconds']:.1f} s, {len(last['points'])} reward points",
              flush=True)
    with open(os.path.join(out, "runs.json"), "w", encoding="utf-8") as fh:
        json.dump({"args": {k: v for k, v in vars(args).items()}, "geometry": shape, "runs": runs}, fh, indent=1)
    text = summary(runs, args)
    with open(os.path.join(out, "summary.md"), "w", encoding="utf-8") as fh:
        fh.write(text)
    plot(runs, os.path.join(out, "curves.png"), os.path.basename(args.config))
    print(text)
    return 0 if all(run["returncode"] in (0, 124) for run in runs) else 1


if __name__ == "__main__":
    sys.exit(main())
