"""Per-frame learning curves of RLlib's tuned CartPole PPO (``cartpole_ppo.py``'s settings: lr 3e-4, 6 epochs,
vf_loss_coeff 0.01, one linear layer of 32 shared by policy and value, 2 env runners, RLlib's PPO defaults
otherwise): ``episode_return_mean`` against env steps after every ``train()``, for several seeds, through the
face and (``--rllib-python``) under real RLlib 2.60.

    python benchmarks/peers/rllib_curves.py --seeds 1 2 3 --out /tmp/rllib_curves
    python benchmarks/peers/rllib_curves.py --seeds 1 2 3 --rllib-python /work/peers/rllib/bin/python

Each side runs this file as an RLlib script (``--worker``: RLlib's own imports; the face's through
``python -m rlchain.rllib``), one seed per process, printing one JSON line per iteration. The driver writes
``<out>/<lib>_seed<N>.csv`` (env_steps, episode_return_mean) and prints, per seed, the env steps at which the
return first reached the stop reward (450), then the medians and a table of each side's median return at 20k, 40k,
... 100k env steps (``--table-only`` prints it from the CSVs already in ``--out``). Env steps do not depend on the
machine's load; seconds do and are not reported here (rllib_cartpole.py times both sides).
"""

import argparse
import csv
import json
import os
import statistics
import subprocess
import sys

from rllib_cartpole import STOP_REWARD, tuned_cartpole_config  # this folder: first on sys.path on both sides


def face_options(algo, options: dict) -> None:
    """Set ``params.config`` keys of the face's PPO after it is built (before its first rollout): a variant of the
    translated config, e.g. ``minibatch_order`` / ``advantage_normalization`` without RLlib's batch."""
    import dataclasses

    ppo = algo._stepper.context.algorithm
    ppo.cfg = ppo.agent.cfg = dataclasses.replace(ppo.cfg, **options)


def worker(seed: int, runners: int, max_steps: int, options: dict | None = None) -> None:
    algo = tuned_cartpole_config(seed, runners).build_algo()
    lib = "rlchain" if type(algo).__module__.startswith("rlchain") else "rllib"
    if options and lib == "rlchain":
        face_options(algo, options)
    steps = 0
    while steps < max_steps:
        result = algo.train()
        env_runners = result.get("env_runners") or {}
        steps = int(env_runners.get("num_env_steps_sampled_lifetime")
                    or result.get("num_env_steps_sampled_lifetime") or 0)
        ret = float(env_runners.get("episode_return_mean", float("nan")))
        print(json.dumps({"lib": lib, "seed": seed, "env_steps": steps, "return": ret}), flush=True)
        if ret >= STOP_REWARD:
            break
    algo.stop()


def frames_to(rows: list[dict], reward: float) -> int | None:
    """Env steps of the first iteration whose mean return reached ``reward`` (None: never)."""
    return next((r["env_steps"] for r in rows if r["return"] >= reward), None)


def return_at(rows: list[tuple[int, float]], frames: int) -> float:
    """The reported return of the first iteration at or past ``frames`` env steps; a run that stopped earlier (it
    reached the stop reward) keeps its last value."""
    for steps, ret in rows:
        if steps >= frames:
            return ret
    return rows[-1][1] if rows else float("nan")


def frame_table(out: str, libs: list[str], seeds: list[int], frames: list[int]) -> list[str]:
    """A markdown table of the median (over ``seeds``) return at each of ``frames`` env steps, from the CSVs."""
    lines = ["| env steps | " + " | ".join(f"{lib}: median return (min-max, seeds)" for lib in libs) + " |",
             "|---|" + "---|" * len(libs)]
    curves = {}
    for lib in libs:
        for seed in seeds:
            path = os.path.join(out, f"{lib}_seed{seed}.csv")
            if os.path.exists(path):
                with open(path) as f:
                    curves[lib, seed] = [(int(r["env_steps"]), float(r["episode_return_mean"]))
                                         for r in csv.DictReader(f)]
    for frames_at in frames:
        cells = []
        for lib in libs:
            values = [return_at(curves[lib, s], frames_at) for s in seeds if (lib, s) in curves]
            values = [v for v in values if v == v]
            cells.append(f"{statistics.median(values):.0f} ({min(values):.0f}-{max(values):.0f}, {len(values)} seeds)"
                         if values else "-")
        lines.append(f"| {frames_at:,} | " + " | ".join(cells) + " |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worker", action="store_true", help="run the RLlib script itself (one side, one seed)")
    parser.add_argument("--rllib-python", default=None,
                        help="also run real RLlib with this Python (a venv with ray[rllib]==2.60.0)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--num-env-runners", type=int, default=2)
    parser.add_argument("--max-steps", type=int, default=400_000, help="give up after this many env steps")
    parser.add_argument("--out", default="rllib_curves", help="folder for the CSV curves (outside git)")
    parser.add_argument("--frames", type=int, nargs="+", default=[20_000, 40_000, 60_000, 80_000, 100_000],
                        help="env steps at which the closing table gives each side's median return")
    parser.add_argument("--table-only", action="store_true", help="only print the table of the CSVs in --out")
    parser.add_argument("--face-option", action="append", default=[],
                        help="KEY=VALUE (a JSON value): a params.config key of the face's PPO, set after it is "
                             "built, e.g. minibatch_order='\"shuffle\"' minibatch_size=125 "
                             "advantage_normalization='\"batch\"' (the face before RLlib's batch)")
    args = parser.parse_args()
    options = {k: json.loads(v) for k, v in (o.split("=", 1) for o in args.face_option)}
    if args.table_only:
        print("\n".join(frame_table(args.out, ["rllib", "rlchain"], args.seeds, args.frames)))
        return
    if args.worker:
        worker(args.seed, args.num_env_runners, args.max_steps, options)
        return
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    here = os.path.abspath(__file__)
    os.makedirs(args.out, exist_ok=True)
    sides = {"rlchain": ([sys.executable, "-m", "rlchain.rllib"],
                         {**os.environ, "PYTHONPATH": root, "OMP_NUM_THREADS": "1"})}
    if args.rllib_python:
        sides["rllib"] = ([args.rllib_python], {k: v for k, v in os.environ.items() if k != "PYTHONPATH"})
    found: dict[str, list[int | None]] = {lib: [] for lib in sides}
    for seed in args.seeds:
        for lib, (python, env) in sides.items():
            cmd = [*python, here, "--worker", "--seed", str(seed), "--num-env-runners", str(args.num_env_runners),
                   "--max-steps", str(args.max_steps), *(f"--face-option={o}" for o in args.face_option)]
            out = subprocess.run(cmd, env=env, capture_output=True, text=True)
            rows = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]
            if out.returncode or not rows:
                print(f"{lib} seed {seed}: failed (exit {out.returncode}): {out.stderr.strip()[-500:]}", flush=True)
                continue
            path = os.path.join(args.out, f"{lib}_seed{seed}.csv")
            with open(path, "w", newline="") as f:
                writer = csv.writer(f)
                writer.writerow(["env_steps", "episode_return_mean"])
                writer.writerows([r["env_steps"], r["return"]] for r in rows)
            steps = frames_to(rows, STOP_REWARD)
            found[lib].append(steps)
            print(f"{lib} seed {seed}: {'not reached' if steps is None else f'{steps} env steps'} to "
                  f"{STOP_REWARD:.0f} ({len(rows)} iterations; curve: {path})", flush=True)
    for lib, values in found.items():
        reached = [v for v in values if v is not None]
        if reached:
            print(f"{lib}: median {statistics.median(reached):.0f} env steps to {STOP_REWARD:.0f} "
                  f"({len(reached)} of {len(values)} seeds reached it)", flush=True)
    print("\n".join(frame_table(args.out, list(sides), args.seeds, args.frames)), flush=True)


if __name__ == "__main__":
    main()
