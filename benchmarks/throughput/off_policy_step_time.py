"""CPU milliseconds per off-policy gradient step: rlchain's SAC and DQN in this tree and in another checkout, and
Stable-Baselines3's SAC, timed in turns in one run.

Each side is one long-lived worker process at one torch thread (a fresh process per measurement would spend more
time importing than measuring). An rlchain worker trains its tree's shipped config (``sac_pendulum`` /
``dqn_cartpole``, ``--batch`` replacing the config's batch size) through the warmup until its replay buffer holds
a batch, parks the run between two epochs, then times gradient steps as the off-policy epoch makes them: a
replay sample, the agent's update, the priorities written back, the step's statistics summed, their means read
once per measurement. The SB3 worker fills SB3's buffer with ``learn()`` and times ``model.train(gradient_steps=N,
batch_size=B)`` on Pendulum-v1 (its MlpPolicy with ``--sb3-net``: ``ours`` is sac_pendulum's [128, 128] ReLU,
``sb3`` SB3's default [256, 256]). Every round asks every worker for one measurement, in a rotated order, so a
change of the machine's load falls on every side. One more worker of this tree measures what the RLlib face's
extra statistics cost (``rllib_stats``, set by the face on the agent it trains): it alternates blocks of 10 steps
with the flag off and on inside one process, so load drift falls on both (``--no-face-side`` leaves it out). The
table gives each side's median, quartiles and range over the rounds, and the per-round ratios of this tree to the
base and of the flag on to off::

    python benchmarks/throughput/off_policy_step_time.py --base-tree /tmp/old_checkout --rounds 9

CPU time is the worker's (``time.process_time``); wall time is printed beside it. On a loaded machine the CPU
times are the figure to read, and still only roughly (caches and memory bandwidth are shared).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

if __package__ in (None, ""):  # run by path: this checkout's benchmarks first
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from benchmarks.common import REPO, cpu_model, load_average  # noqa: E402

CONFIGS = {"sac": "sac_pendulum", "dqn": "dqn_cartpole"}
SB3_NETS = {"ours": [128, 128], "sb3": [256, 256]}


# ----- the workers (each in a process of its own) ---------------------------------------------------------------
def rlchain_worker(tree: str, algo: str, batch: int, seed: int) -> tuple[object, str, object]:
    """A parked rlchain run of ``tree``'s shipped config for ``algo`` with a batch in its buffer; its timer, what
    it is, its agent."""
    sys.path.insert(0, os.path.abspath(tree))
    import torch
    import yaml

    import rlchain
    if not os.path.abspath(rlchain.__file__).startswith(os.path.abspath(tree) + os.sep):
        raise SystemExit(f"off_policy_step_time.py: imported {rlchain.__file__}, not {tree}'s rlchain")
    from rlchain import Runner
    from rlchain.tuning.epochs import EpochStepper

    torch.set_num_threads(1)
    with open(os.path.join(tree, "rlchain", "configs", CONFIGS[algo] + ".yaml")) as f:
        config = yaml.safe_load(f)
    cfg = config["params"]["config"]
    cfg.update(batch_size=batch, train_dir=os.path.abspath("runs"), print_stats=False,  # in the worker's folder
               max_frames=10**9, score_to_win=10**9)
    stepper = EpochStepper(Runner().load(config), seed=seed)
    while True:
        stepper.next_epoch()
        run = stepper.context.algorithm
        if stepper.context.state.frames >= cfg["num_warmup_frames"] and len(run.buffer) >= batch:
            break
    agent, buffer = run.agent, run.buffer

    def steps(n: int) -> None:  # the off-policy epoch's update round (rlchain.algos.off_policy.off_policy)
        run.model.train()
        sums: dict = {}
        for _ in range(n):
            sample = buffer.sample(batch, beta=run._beta())
            stats, td = agent.update(sample)
            buffer.update_priorities(sample["indices"], td)
            for k, v in stats.items():
                sums[k] = sums.get(k, 0.0) + v
        steps.means = {k: float(v) / n for k, v in sums.items()}  # the epoch's one read of the sums

    return steps, f"{os.path.abspath(rlchain.__file__)} (rllib_stats {getattr(agent, 'rllib_stats', 'absent')})", \
        agent


def sb3_worker(net: str, batch: int, seed: int) -> tuple[object, str, None]:
    """SB3's SAC on Pendulum-v1 with a batch in its buffer; its timer."""
    import stable_baselines3
    import torch
    from stable_baselines3 import SAC

    torch.set_num_threads(1)
    model = SAC("MlpPolicy", "Pendulum-v1", batch_size=batch, learning_starts=1000, seed=seed, device="cpu",
                policy_kwargs={"net_arch": SB3_NETS[net]}, verbose=0)
    model.learn(total_timesteps=1000 + batch)

    def steps(n: int) -> None:
        model.train(gradient_steps=n, batch_size=batch)

    return steps, f"stable_baselines3 {stable_baselines3.__version__}, net_arch {SB3_NETS[net]}", None


def worker_main(spec: dict) -> None:
    """Build the side ``spec`` names, say it is ready, then time ``n`` gradient steps for each ``n`` read (with
    ``toggle``: ``n`` with the agent's ``rllib_stats`` off and ``n`` with it on, in alternating blocks of 10)."""
    if spec["kind"] == "sb3":
        steps, said, agent = sb3_worker(spec["net"], spec["batch"], spec["seed"])
    else:
        steps, said, agent = rlchain_worker(spec["tree"], spec["algo"], spec["batch"], spec["seed"])
    toggle = spec.get("toggle", False)
    if toggle:
        said = said.split(" (")[0] + " (rllib_stats off and on in turns)"
    steps(5)  # the first steps allocate (Adam's state, the allocator's pools)
    print(json.dumps({"ready": said}), flush=True)
    for line in sys.stdin:
        n = int(line)
        cpu, wall = {False: 0.0, True: 0.0}, {False: 0.0, True: 0.0}
        for block in range(max(n // 10, 1) if toggle else 1):
            for flag in ((False, True) if block % 2 == 0 else (True, False)) if toggle else (False,):
                if toggle:
                    agent.rllib_stats = flag
                c0, w0 = time.process_time(), time.perf_counter()
                steps(10 if toggle else n)
                cpu[flag] += time.process_time() - c0
                wall[flag] += time.perf_counter() - w0
        n = max(n // 10, 1) * 10 if toggle else n
        out = {"cpu_ms": cpu[toggle] * 1e3 / n, "wall_ms": wall[toggle] * 1e3 / n}
        if toggle:
            out.update(cpu_off_ms=cpu[False] * 1e3 / n, wall_off_ms=wall[False] * 1e3 / n)
        print(json.dumps(out), flush=True)
    os._exit(0)  # the parked training thread and its writers end with the process


# ----- the driver ----------------------------------------------------------------------------------------------
class Side:
    """One worker process and its measurements."""

    def __init__(self, label: str, algo: str, spec: dict, folder: str) -> None:
        self.label, self.algo, self.cpu, self.wall, self.cpu_off = label, algo, [], [], []
        env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        env.pop("PYTHONPATH", None)  # each worker puts its own tree first
        self.proc = subprocess.Popen([sys.executable, os.path.abspath(__file__), "--worker", json.dumps(spec)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env,
                                     cwd=tempfile.mkdtemp(dir=folder))  # its run folders, removed at the end
        self.said = self._read()["ready"]

    def _read(self) -> dict:
        line = self.proc.stdout.readline()
        if not line:
            raise SystemExit(f"off_policy_step_time.py: the {self.label} worker ended (its error is above)")
        return json.loads(line)

    def measure(self, n: int) -> None:
        self.proc.stdin.write(f"{n}\n")
        self.proc.stdin.flush()
        out = self._read()
        self.cpu.append(out["cpu_ms"])
        self.wall.append(out["wall_ms"])
        if "cpu_off_ms" in out:
            self.cpu_off.append(out["cpu_off_ms"])

    def close(self) -> None:
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=60)
        except (OSError, subprocess.TimeoutExpired):  # a worker that died already, or hangs: ended here
            self.proc.kill()
            self.proc.wait()


def spread(values: list[float]) -> str:
    """median [q1 - q3] (min - max)."""
    q = statistics.quantiles(values, n=4, method="inclusive") if len(values) > 1 else [values[0]] * 3
    return f"{statistics.median(values):7.2f} [{q[0]:.2f}-{q[2]:.2f}] ({min(values):.2f}-{max(values):.2f})"


def machine_line() -> str:
    """The load average now, and ``uptime``'s line."""
    uptime = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    return f"load {load_average():.2f} (1 min); uptime: {uptime}"


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--base-tree", help="another rlchain checkout to time beside this one (git worktree add DIR REV)")
    p.add_argument("--algos", nargs="+", default=["sac", "dqn"], choices=sorted(CONFIGS))
    p.add_argument("--sb3-net", nargs="*", default=["ours", "sb3"], choices=sorted(SB3_NETS),
                   help="SB3 SAC sides by network (none: no SB3 side)")
    p.add_argument("--batch", type=int, default=256)
    p.add_argument("--rounds", type=int, default=9)
    p.add_argument("--steps", type=int, nargs=2, default=[100, 400], metavar=("SAC", "DQN"),
                   help="gradient steps per measurement")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--no-face-side", action="store_true",
                   help="leave out the worker timing this tree's agents with rllib_stats off and on")
    p.add_argument("--worker", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        worker_main(json.loads(args.worker))
        return
    trees = [("this", REPO)] + ([("base", args.base_tree)] if args.base_tree else [])
    for _, tree in trees:
        if not os.path.isdir(os.path.join(tree, "rlchain")):
            raise SystemExit(f"off_policy_step_time.py: --base-tree {tree}: no rlchain checkout there")
    print(f"CPU: {cpu_model()}; batch {args.batch}; one torch thread per worker; {args.rounds} rounds")
    print(f"start: {machine_line()}")
    sides: list[Side] = []
    folder = tempfile.TemporaryDirectory(prefix="off_policy_step_time_")  # the workers' run folders
    try:
        for algo in args.algos:
            for name, tree in trees:
                spec = {"kind": "rlchain", "tree": tree, "algo": algo, "batch": args.batch, "seed": args.seed}
                sides.append(Side(f"{algo} rlchain {name}", algo, spec, folder.name))
            if not args.no_face_side:  # this tree's agent as the RLlib face runs it, and as rlchain does
                spec = {"kind": "rlchain", "tree": REPO, "algo": algo, "batch": args.batch, "seed": args.seed,
                        "toggle": True}
                sides.append(Side(f"{algo} rlchain this+rllib", algo, spec, folder.name))
            if algo == "sac":
                for net in args.sb3_net:
                    spec = {"kind": "sb3", "net": net, "batch": args.batch, "seed": args.seed}
                    sides.append(Side(f"sac sb3 net={net}", algo, spec, folder.name))
        for side in sides:
            print(f"  {side.label:24s} {side.said}")
        for r in range(args.rounds):
            k = r % len(sides)
            for side in sides[k:] + sides[:k]:  # rotated: no side always runs first or last
                side.measure(args.steps[0] if side.algo == "sac" else args.steps[1])
        print(f"end:   {machine_line()}")
        print(f"\n{'side':24s} CPU ms per gradient step: median [q1-q3] (min-max)   wall ms median")
        for side in sides:
            print(f"{side.label:24s} {spread(side.cpu):45s} {statistics.median(side.wall):7.2f}")
            if side.cpu_off:
                print(f"{'  same process, flag off':24s} {spread(side.cpu_off)}")
        print("\nCPU ms per step, per round (paired): median ratio (min-max), rounds the first was faster")
        for algo in args.algos:
            by_name = {s.label.split(" rlchain ")[1]: s for s in sides if s.label.startswith(f"{algo} rlchain ")}
            pairs = []
            if "base" in by_name:
                pairs.append(("this / base", by_name["this"].cpu, by_name["base"].cpu))
            if "this+rllib" in by_name:
                pairs.append(("rllib_stats on / off (one process)", by_name["this+rllib"].cpu,
                              by_name["this+rllib"].cpu_off))
            for label, first, second in pairs:
                ratios = [a / b for a, b in zip(first, second)]
                faster = sum(r < 1 for r in ratios)
                print(f"{algo} {label}: {statistics.median(ratios):.3f} ({min(ratios):.3f}-{max(ratios):.3f}), "
                      f"{faster} of {len(ratios)}")
    finally:
        for side in sides:
            side.close()
        folder.cleanup()


if __name__ == "__main__":
    main()
