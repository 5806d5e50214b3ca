"""Compare rlchain with the peer libraries rl_games and Stable-Baselines3.

rlchain and rl_games train on one rl_games-format YAML config; the optional
``sb3`` column is Stable-Baselines3 PPO with rl-baselines3-zoo's tuned
CartPole-v1 hyperparameters (``sb3_driver.py``; the config must be a
CartPole-v1 one, and only its ``score_to_win`` is used).  Each library
trains as a subprocess in its own fresh temporary working directory and
writes TensorBoard events under ``runs/<name>_<date>/summaries`` with the tag
``rewards/step`` (x = frames, y = mean episode reward).  This script reads
those events with TensorBoard's EventAccumulator and reports

* time-to-score: seconds from subprocess start to the wall time of the first
  ``rewards/step`` event whose value is >= the threshold,
* frames-to-score: the step (frames) of that event,
* end-to-end fps: last step / (last event wall time - subprocess start),
* steady fps: frames / seconds between the first and the last event,
* startup: seconds from subprocess start to the first event,
* score - startup: time-to-score minus startup (training time, roughly),
* the last and best mean reward and the frames of the last event.

Example::

    python benchmarks/peers/compare.py benchmarks/rl_games_configs/ppo_cartpole.yaml \\
        --threshold 400 --max-seconds 600 --stop-at-score \\
        --rl-games-python /work/rlg-venv/bin/python \\
        --sb3-python /work/rlg-venv/bin/python
"""

import argparse
import glob
import importlib.util
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import yaml

TAG = "rewards/step"
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def read_rewards(workdir, accs, tag=TAG):
    """Return sorted (wall_time, step, value) of ``tag`` (default TAG) from all event files.

    ``accs`` caches one EventAccumulator per summaries directory so repeated
    calls only read what was appended since the last call.
    """
    from tensorboard.backend.event_processing import event_accumulator as ea

    pattern = os.path.join(workdir, "runs", "**", "events.out.tfevents.*")
    for path in glob.glob(pattern, recursive=True):
        d = os.path.dirname(path)
        if d not in accs:
            accs[d] = ea.EventAccumulator(d, size_guidance={ea.SCALARS: 0})
    events = []
    for acc in accs.values():
        acc.Reload()
        if tag in acc.Tags().get("scalars", []):
            events += [(e.wall_time, e.step, e.value) for e in acc.Scalars(tag)]
    return sorted(events)


def metrics(events, t0, threshold):
    """Compute the benchmark metrics from (wall_time, step, value) events."""
    keys = ("time_to_score_s", "train_to_score_s", "frames_to_score", "fps",
            "steady_fps", "startup_s", "last_frames", "last_reward", "best_reward")
    m = dict.fromkeys(keys)
    m["num_points"] = len(events)
    if not events:
        return m
    (w0, s0, _), (wall, step, value) = events[0], events[-1]
    m.update(last_frames=step, last_reward=value, startup_s=w0 - t0,
             best_reward=max(e[2] for e in events))
    if wall > t0:
        m["fps"] = step / (wall - t0)
    if wall > w0:
        m["steady_fps"] = (step - s0) / (wall - w0)
    if threshold is not None:
        for wall, step, value in events:
            if value >= threshold:
                m.update(time_to_score_s=wall - t0, frames_to_score=step,
                         train_to_score_s=wall - w0)
                break
    return m


def stop(proc, grace=10.0):
    """Stop a subprocess started in its own session, and its children.

    SIGINT, then SIGTERM, to the leader (a Python trainer then runs its
    atexit hooks, which flush TensorBoard writers and shut Ray down), then
    SIGKILL to the whole process group (leftover Ray or compile workers).
    """
    for sig in (signal.SIGINT, signal.SIGTERM):
        if proc.poll() is not None:
            break
        try:
            os.kill(proc.pid, sig)
            proc.wait(grace)
        except (ProcessLookupError, subprocess.TimeoutExpired):
            pass
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    proc.wait()


def run_one(name, cmd, threshold, max_seconds, stop_at_score, keep, poll):
    """Run one training command in a fresh temp dir; return its metrics."""
    workdir = tempfile.mkdtemp(prefix=f"bench_{name}_")
    log_path = os.path.join(workdir, "train.log")
    print(f"[{name}] cwd={workdir}\n[{name}] $ {shlex.join(cmd)}", flush=True)
    accs, reason = {}, "exited"
    with open(log_path, "wb") as log:
        t0 = time.time()
        proc = subprocess.Popen(cmd, cwd=workdir, stdout=log, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, start_new_session=True)
        try:
            while proc.poll() is None:
                time.sleep(poll)
                if time.time() - t0 >= max_seconds:
                    reason = "max_seconds"
                    break
                if stop_at_score and threshold is not None:
                    m = metrics(read_rewards(workdir, accs), t0, threshold)
                    if m["time_to_score_s"] is not None:
                        reason = "score"
                        break
        finally:
            stop(proc)
    elapsed = time.time() - t0
    m = metrics(read_rewards(workdir, accs), t0, threshold)
    m.update(cmd=cmd, returncode=proc.returncode, stop_reason=reason, wall_s=elapsed,
             workdir=workdir if keep else None)
    if reason == "exited" and proc.returncode != 0:
        with open(log_path, "rb") as f:
            tail = f.read()[-3000:].decode(errors="replace")
        print(f"[{name}] FAILED rc={proc.returncode}; log tail:\n{tail}", file=sys.stderr)
    if not keep:
        shutil.rmtree(workdir, ignore_errors=True)
    print(f"[{name}] done: {reason}, {elapsed:.0f}s, "
          f"last reward {m['last_reward']} at {m['last_frames']} frames",
          flush=True)
    return m


PEERS = ("rl_games", "sb3")
ROWS = [  # key, label, ratio: "time" = peer/rlchain, "fps" = rlchain/peer
    ("time_to_score_s", "time-to-score (s)", "time"),
    ("train_to_score_s", "score - startup (s)", "time"),
    ("frames_to_score", "frames-to-score", "time"),
    ("fps", "end-to-end fps", "fps"),
    ("steady_fps", "steady fps", "fps"),
    ("startup_s", "startup (s)", "time"),
    ("last_frames", "frames at end", None),
    ("last_reward", "reward at end", None),
    ("best_reward", "best reward", None),
    ("wall_s", "wall time (s)", None),
    ("stop_reason", "stop reason", None),
]


def fmt(v):
    """Format one table cell."""
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.1f}" if abs(v) >= 10 else f"{v:.3g}"
    return str(v)


def ratio(kind, x, y):
    """rlchain value x vs peer value y: y/x for times, x/y for fps."""
    if not kind or not all(isinstance(v, (int, float)) for v in (x, y)):
        return "-"
    num, den = (y, x) if kind == "time" else (x, y)
    return f"{num / den:.2f}" if den else "-"


def table(results):
    """Render the side-by-side table (one column per library run) as text."""
    names = [n for n in ("rlchain",) + PEERS if n in results]
    peers = [n for n in PEERS if n in results] if "rlchain" in results else []
    head = [f"{'metric':<20}"] + [f"{n:>12}" for n in names]
    head += [f"{'ratio ' + p:>14}" for p in peers]
    lines = [" | ".join(head), "-" * len(" | ".join(head))]
    for key, label, kind in ROWS:
        row = [f"{label:<20}"] + [f"{fmt(results[n].get(key)):>12}" for n in names]
        row += [f"{ratio(kind, results['rlchain'].get(key), results[p].get(key)):>14}"
                for p in peers]
        lines.append(" | ".join(row))
    return "\n".join(lines)


def parse_args(argv=None):
    """Parse the command line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("config", help="YAML config (rl_games format)")
    p.add_argument("--threshold", type=float, default=None,
                   help="reward to reach (default: config's score_to_win)")
    p.add_argument("--max-seconds", type=float, default=600.0)
    p.add_argument("--stop-at-score", action="store_true",
                   help="kill a run once its threshold is reached")
    p.add_argument("--only", choices=("rlchain",) + PEERS)
    p.add_argument("--repo", default=REPO, help="rlchain repo root")
    p.add_argument("--rlchain-python", default=sys.executable)
    p.add_argument("--rl-games-python", default=None,
                   help="interpreter with rl_games installed (default: this "
                        "one if it can import rl_games)")
    p.add_argument("--rlchain-args", default="", help="extra runner.py args")
    p.add_argument("--rl-games-args", default="",
                   help="extra rl_games_driver.py args, e.g. "
                        "'--torch-compile off'")
    p.add_argument("--sb3-python", default=None,
                   help="interpreter with stable-baselines3; adds the sb3 "
                        "column (default: none, or this one with --only sb3)")
    p.add_argument("--sb3-args", default="",
                   help="extra sb3_driver.py args, e.g. '--seed 1'")
    p.add_argument("--poll", type=float, default=5.0, help="poll period (s)")
    p.add_argument("--keep", action="store_true", help="keep the temp dirs")
    p.add_argument("--json", dest="json_out", help="write results here")
    return p.parse_args(argv)


def main(argv=None):
    """Run the requested libraries and print the comparison table."""
    args = parse_args(argv)
    cfg_path = os.path.abspath(args.config)
    threshold = args.threshold
    with open(cfg_path) as f:
        cfg = yaml.safe_load(f)["params"]["config"]
    if threshold is None:
        threshold = cfg.get("score_to_win")
    rlg_py = args.rl_games_python
    if rlg_py is None and importlib.util.find_spec("rl_games") is not None:
        rlg_py = sys.executable
    sb3_py = args.sb3_python
    if (sb3_py is None and args.only == "sb3"
            and importlib.util.find_spec("stable_baselines3") is not None):
        sb3_py = sys.executable
    cmds = {}
    if args.only in (None, "rlchain"):
        cmds["rlchain"] = [args.rlchain_python,
                           os.path.join(args.repo, "runner.py"), "--train",
                           "--file", cfg_path] + shlex.split(args.rlchain_args)
    if args.only in (None, "rl_games"):
        if rlg_py is None:
            print("[rl_games] skipped: rl_games not importable here and no "
                  "--rl-games-python given", file=sys.stderr)
        else:
            driver = os.path.join(args.repo, "benchmarks", "peers", "rl_games_driver.py")
            cmds["rl_games"] = ([rlg_py, driver, "--file", cfg_path]
                                + shlex.split(args.rl_games_args))
    if args.only in (None, "sb3") and (sb3_py or args.only):
        if sb3_py is None:
            print("[sb3] skipped: stable_baselines3 not importable here and "
                  "no --sb3-python given", file=sys.stderr)
        elif cfg.get("env_name") != "CartPole-v1":
            print("[sb3] skipped: sb3_driver.py only trains CartPole-v1",
                  file=sys.stderr)
        else:
            driver = os.path.join(args.repo, "benchmarks", "peers", "sb3_driver.py")
            sb3_thr = [] if threshold is None else ["--threshold", str(threshold)]
            cmds["sb3"] = ([sb3_py, driver] + sb3_thr
                           + shlex.split(args.sb3_args))
    results = {name: run_one(name, cmd, threshold, args.max_seconds,
                             args.stop_at_score, args.keep, args.poll)
               for name, cmd in cmds.items()}
    print(f"\nconfig: {args.config}   threshold: {threshold}   "
          f"max-seconds: {args.max_seconds:g}")
    print(table(results))
    if args.json_out:
        with open(args.json_out, "w") as f:
            json.dump({"config": cfg_path, "threshold": threshold,
                       "max_seconds": args.max_seconds,
                       "date": time.strftime("%Y-%m-%d %H:%M:%S"),
                       "results": results}, f, indent=2)
    return 0 if results else 1


if __name__ == "__main__":
    sys.exit(main())
