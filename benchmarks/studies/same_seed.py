"""Same seed, same checkpoint: train a few small configs for 2-3 epochs with a fixed seed under two source trees
and compare every tensor of the two last checkpoints (model, optimizer state, extras) and every number.

    python benchmarks/studies/same_seed.py --before /work/base --after . [--cases ppo_mlp sac ...]

Each run is a child process with ``PYTHONPATH`` set to its tree, ``OMP_NUM_THREADS=1`` and one torch thread,
started in that tree (relative paths such as a distill teacher's ``nn/cartpole.pth`` resolve there). A case
passes when both checkpoints hold the same keys and bit-identical values; what differs is listed by key path.
Values that measure time (``time``, ``seconds``, ``fps``) and the run folder's name are not compared;
``params.torch_threads=1`` pins the thread count (on a CPU it otherwise follows the machine's load, and an LSTM's
sums with it).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

CASES: dict[str, tuple[str, list[str]]] = {
    "ppo_mlp": ("ppo_cartpole.yaml", ["params.config.max_epochs=3"]),
    "ppo_lstm": ("ppo_cartpole_masked_velocity_rnn.yaml", ["params.config.max_epochs=2"]),
    "central_value": ("ppo_cartpole.yaml", [
        "params.config.max_epochs=3", "params.config.env_name=SameSeedObsStateCartPole-v0",
        "params.config.normalize_value=True",
        "params.config.central_value_config={network: {name: actor_critic, central_value: True, "
        "mlp: {units: [32]}}, learning_rate: 1e-3, mini_epochs: 2, lr_schedule: linear}"]),
    "sac": ("sac_pendulum.yaml", ["params.config.max_epochs=3", "params.config.num_warmup_frames=40",
                                  "params.config.batch_size=32"]),
    "dqn": ("dqn_cartpole.yaml", ["params.config.max_epochs=3", "params.config.num_warmup_frames=40",
                                  "params.config.batch_size=32"]),
    "grpo": ("grpo_torch_cartpole.yaml", ["params.config.max_epochs=2", "params.config.num_actors=16",
                                          "params.config.horizon_length=32", "params.config.minibatch_size=128"]),
    "multi_policy": ("ppo_pz_simple_tag.yaml", ["params.config.max_epochs=2", "params.config.num_actors=2",
                                                "params.config.minibatch_size=100"]),
    "distill": ("distill_cartpole_lstm.yaml", ["params.config.max_epochs=2", "params.config.num_actors=8",
                                               "params.config.horizon_length=16"]),
    "apg": ("apg_point_mass.yaml", ["params.config.max_epochs=3", "params.config.num_actors=8",
                                    "params.config.horizon_length=10"]),
}

SKIPPED = ("time", "seconds", "fps", "run_dir", "train_dir", "started", "date", "path")


def child(case: str, out: str) -> None:
    """Train ``case`` in this process (the tree on PYTHONPATH) and print its last checkpoint's path."""
    import gymnasium as gym
    import numpy as np
    import torch

    torch.set_num_threads(1)

    class ObsStateCartPole(gym.Wrapper):
        """CartPole whose actor sees position and angle, and whose critic sees the full state."""

        def __init__(self, env: gym.Env) -> None:
            super().__init__(env)
            box = env.observation_space
            self.observation_space = gym.spaces.Dict({
                "obs": gym.spaces.Box(box.low[[0, 2]], box.high[[0, 2]], dtype=np.float32), "state": box})

        def _split(self, obs):
            return {"obs": obs[[0, 2]].astype(np.float32), "state": obs.astype(np.float32)}

        def reset(self, **kwargs):
            obs, info = self.env.reset(**kwargs)
            return self._split(obs), info

        def step(self, action):
            obs, reward, terminated, truncated, info = self.env.step(action)
            return self._split(obs), reward, terminated, truncated, info

    gym.register("SameSeedObsStateCartPole-v0",
                 entry_point=lambda **kw: ObsStateCartPole(gym.make("CartPole-v1", **kw)))
    from rlchain import Runner

    name, extra = CASES[case]
    config = os.path.join("rlchain", "configs", name)
    overrides = [f"params.config.train_dir={out}", "params.config.print_stats=false", "params.seed=7",
                 "params.torch_threads=1",
                 "params.config.save_best_after=100000", *extra]
    result = Runner().load(config, overrides).train()
    nn = os.path.join(result.run_dir, "nn")
    last = sorted(f for f in os.listdir(nn) if f.startswith("last"))
    print("CHECKPOINT=" + os.path.join(nn, last[-1]))


def train(tree: str, case: str, out: str) -> str:
    env = {**os.environ, "PYTHONPATH": os.path.abspath(tree), "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", case, out], cwd=tree, env=env,
                          capture_output=True, text=True)
    for line in proc.stdout.splitlines():
        if line.startswith("CHECKPOINT="):
            return line.split("=", 1)[1]
    raise RuntimeError(f"{case} under {tree} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")


def differences(a, b, path: str = "") -> list[str]:
    """Key paths where ``a`` and ``b`` differ (tensors bit for bit; time measurements skipped)."""
    import torch

    if any(word in path.rsplit(".", 1)[-1].lower() for word in SKIPPED):
        return []
    if isinstance(a, torch.Tensor) or isinstance(b, torch.Tensor):
        if not (isinstance(a, torch.Tensor) and isinstance(b, torch.Tensor)):
            return [f"{path}: tensor on one side only"]
        if a.shape != b.shape or a.dtype != b.dtype:
            return [f"{path}: {tuple(a.shape)} {a.dtype} vs {tuple(b.shape)} {b.dtype}"]
        same = torch.equal(a, b) or (a.is_floating_point() and torch.equal(a.isnan(), b.isnan())
                                     and torch.equal(a.nan_to_num(), b.nan_to_num()))
        return [] if same else [f"{path}: max |diff| {float((a.double() - b.double()).abs().max()):.3g}"]
    if isinstance(a, dict) and isinstance(b, dict):
        out = [f"{path}.{k}: only before" for k in a if k not in b]
        out += [f"{path}.{k}: only after" for k in b if k not in a]
        for k in a:
            if k in b:
                out += differences(a[k], b[k], f"{path}.{k}")
        return out
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if len(a) != len(b):
            return [f"{path}: length {len(a)} vs {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in differences(x, y, f"{path}[{i}]")]
    try:
        equal = a == b or (a != a and b != b)
    except Exception:
        equal = repr(a) == repr(b)
    return [] if equal else [f"{path}: {a!r:.60} vs {b!r:.60}"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", default="/work/base")
    parser.add_argument("--after", default=".")
    parser.add_argument("--cases", nargs="*", default=list(CASES))
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(*args.child)
        return
    import torch

    report = {}
    with tempfile.TemporaryDirectory() as tmp:
        for case in args.cases:
            paths = [train(tree, case, os.path.join(tmp, side, case))
                     for side, tree in (("before", args.before), ("after", args.after))]
            before, after = (torch.load(p, map_location="cpu", weights_only=False) for p in paths)
            found = differences(before, after, "checkpoint")
            tensors = sum(1 for _ in _tensors(before))
            report[case] = "identical" if not found else found
            print(f"{case:14s} {'identical' if not found else 'DIFFERENT'} ({tensors} tensors compared)"
                  + "".join(f"\n    {d}" for d in found[:20]), flush=True)
    print(json.dumps({k: v if v == "identical" else len(v) for k, v in report.items()}))
    sys.exit(0 if all(v == "identical" for v in report.values()) else 1)


def _tensors(x):
    import torch

    if isinstance(x, torch.Tensor):
        yield x
    elif isinstance(x, dict):
        for v in x.values():
            yield from _tensors(v)
    elif isinstance(x, (list, tuple)):
        for v in x:
            yield from _tensors(v)


if __name__ == "__main__":
    main()
