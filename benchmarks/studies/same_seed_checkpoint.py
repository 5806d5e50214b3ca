"""Same seed, two trees: train a few configs for 3 epochs in each and compare every tensor of the checkpoints.

    python benchmarks/studies/same_seed_checkpoint.py --before /work/base --after .

Each side runs in its own process with ``PYTHONPATH`` at its tree and ``OMP_NUM_THREADS=1``. The actor-critic
network's tensors carry rl_games' names since the network took rl_games' layout (``network.actor_trunk.mlp.net.
<layer>.0`` -> ``a2c_network.actor_mlp.<2 * layer>``, ``obs_norm.mean`` -> ``running_mean_std.running_mean``,
...): the before side's keys are mapped to the after side's (:func:`renamed`) and every tensor of the two files
(model, central value, optimizer state, RNG streams, counters) must be identical. Prints one line per config.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import subprocess
import sys
import tempfile


def _load_obs_state_cartpole():
    """This checkout's tests/smoke/obs_state_cartpole.py (the central value's env and config, shared with its
    smoke tests), loaded by path: each tree's training process loads the same file."""
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "smoke", "obs_state_cartpole.py")
    spec = importlib.util.spec_from_file_location("obs_state_cartpole", os.path.abspath(path))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


CARTPOLE = _load_obs_state_cartpole()
CASES = {  # name -> (packaged config, overrides)
    "ppo_mlp": ("ppo_cartpole", []),
    "ppo_lstm": ("ppo_cartpole_masked_velocity_rnn", []),
    "ppo_continuous": ("ppo_pendulum", []),
    "ppo_central_value": ("ppo_cartpole", [
        f"params.config.env_name={CARTPOLE.ENV_ID}", "params.config.normalize_value=True",
        f"params.config.central_value_config={CARTPOLE.central_value_config('lr_schedule: linear')}"]),
    "sac": ("sac_pendulum", ["params.config.num_warmup_frames=40", "params.config.batch_size=32"]),
    "dqn": ("dqn_cartpole", ["params.config.num_warmup_frames=40", "params.config.batch_size=32"]),
    "grpo": ("grpo_torch_cartpole", ["params.config.num_actors=16", "params.config.horizon_length=32",
                                     "params.config.minibatch_size=128"]),
    "multi_policy": ("ppo_pz_simple_tag", ["params.config.num_actors=2", "params.config.minibatch_size=100"]),
    "distill": ("distill_cartpole_lstm", ["params.config.num_actors=8", "params.config.horizon_length=16"]),
    "apg": ("apg_point_mass", ["params.config.num_actors=8", "params.config.horizon_length=10"]),
}
EPOCHS = 3

TRAIN = r"""
import importlib.util, json, os, sys
import torch
torch.set_num_threads(1)


spec = importlib.util.spec_from_file_location("obs_state_cartpole", sys.argv[4])  # registers its env id
spec.loader.exec_module(importlib.util.module_from_spec(spec))
from rlchain import Runner
config, out, overrides = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
runner = Runner().load(config, [f"params.config.train_dir={out}", "params.config.print_stats=false", *overrides])
result = runner.train()
print(os.path.join(result.run_dir, "nn"))
"""


def train(tree: str, config: str, overrides: list[str], out: str) -> str:
    """The nn folder of ``config`` trained for EPOCHS epochs in ``tree``."""
    env = {**os.environ, "PYTHONPATH": os.path.abspath(tree), "OMP_NUM_THREADS": "1"}
    # one torch thread for every phase: on a CPU the thread plan otherwise follows the machine's load, and an
    # LSTM's sums with it (the same tree, twice, then differs); the tree's cwd finds a teacher's nn/cartpole.pth
    args = [*overrides, f"params.config.max_epochs={EPOCHS}", "params.config.save_frequency=0",
            "params.torch_threads=1"]
    done = subprocess.run([sys.executable, "-c", TRAIN, os.path.join(tree, "rlchain", "configs", config + ".yaml"),
                           out, json.dumps(args), CARTPOLE.__file__],
                          env=env, cwd=tree, capture_output=True, text=True)
    if done.returncode:
        raise RuntimeError(f"{tree}: {config} failed:\n{done.stderr[-3000:]}")
    return done.stdout.strip().splitlines()[-1]


LAYERS = 2  # hidden layers of the off-policy model being compared (read from its keys)
OFF_POLICY = ("sac", "dqn")
"""Cases whose model is SAC's or DQN's: rl_games' SAC layout (one Sequential a trunk, ``Q1`` / ``Q2``)."""


def renamed_off_policy(key: str, layers: int) -> str:
    """A before-side SAC / DQN key as the after side names it (``layers`` hidden layers: the head after them)."""
    key = re.sub(r"^obs_norm\.", "running_mean_std.", key)
    key = re.sub(r"^running_mean_std\.(mean|var)$", r"running_mean_std.running_\1", key)
    key = re.sub(r"\.trunk\.net\.(\d+)\.(\d+)\.", lambda m: f".trunk.{2 * int(m[1]) + int(m[2])}.", key)
    key = re.sub(r"\.actor\.head\.", f".actor.trunk.{2 * layers}.", key)
    key = re.sub(r"\.(q[12])\.0\.net\.(\d+)\.(\d+)\.", lambda m: f".{m[1].upper()}.{2 * int(m[2]) + int(m[3])}.",
                 key)
    return re.sub(r"\.(q[12])\.1\.", lambda m: f".{m[1].upper()}.{2 * layers}.", key)


def renamed(key: str, actor_critic: bool = True) -> str:
    """A before-side model key as the after side names it (MLPs without norm layers: two modules a layer); a
    multi-policy model's keys keep their ``<policy>.`` prefix."""
    policy = re.match(r"^(\w+)\.(?=(network|obs_norm|value_norm)\.)", key)
    if policy is not None:
        return policy.group(0) + renamed(key[policy.end():], actor_critic)
    if not actor_critic:
        return renamed_off_policy(key, LAYERS)
    key = re.sub(r"^network\.", "a2c_network.", key)
    key = re.sub(r"^obs_norm\.", "running_mean_std.", key)
    key = re.sub(r"^value_norm\.", "value_mean_std.", key)
    key = re.sub(r"(running_mean_std|value_mean_std)\.(mean|var)$", r"\1.running_\2", key)
    key = re.sub(r"\.(actor|critic)_trunk\.mlp\.net\.(\d+)\.(\d+)\.",
                 lambda m: f".{m.group(1)}_mlp.{2 * int(m.group(2)) + int(m.group(3))}.", key)
    key = re.sub(r"\.trunk\.mlp\.net\.(\d+)\.(\d+)\.",  # the central value's one trunk
                 lambda m: f".actor_mlp.{2 * int(m.group(1)) + int(m.group(2))}.", key)
    key = key.replace(".actor_trunk.rnn.norm.", ".layer_norm.").replace(".actor_trunk.rnn.", ".rnn.")
    return key


def _model_part(key: str) -> tuple[str, str]:
    """A checksum key split into its model's part (``model.``, ``central_value.``, a distill checkpoint's
    ``teacher.model.``) and the tensor key; ("", key) for any other part."""
    for part in ("model.", "central_value.", "teacher.model."):
        if key.startswith(part):
            return part, key[len(part):]
    return "", key


def differences(before, after, path: str = "", actor_critic: bool = True) -> list[str]:
    """Where two loaded checkpoints differ (model dicts compared after :func:`renamed`)."""
    import numpy as np
    import torch

    if isinstance(before, dict) and isinstance(after, dict):
        if path.endswith(("model", "central_value")) and all(isinstance(k, str) for k in before):
            global LAYERS
            LAYERS = 1 + max((int(m[1]) for k in before for m in [re.search(r"net\.(\d+)\.\d+\.", k)] if m),
                             default=0)
            before = {renamed(k, actor_critic): v for k, v in before.items()}
        if path.endswith("checksums.tensors"):  # the tensor checksums, keyed by "<part>.<tensor key>"
            before = {(part + renamed(rest, actor_critic) if part else k): v for k, v in before.items()
                      for part, rest in [_model_part(k)]}
        out = [f"{path}: keys {sorted(set(map(str, before)) ^ set(map(str, after)))[:4]}"] \
            if set(before) != set(after) else []
        for key in before:
            if key in after and key != "digest":
                out += differences(before[key], after[key], f"{path}.{key}", actor_critic)
        return out
    if isinstance(before, (list, tuple)) and isinstance(after, (list, tuple)):
        if len(before) != len(after):
            return [f"{path}: length {len(before)} vs {len(after)}"]
        return [d for i, (b, a) in enumerate(zip(before, after))
                for d in differences(b, a, f"{path}[{i}]", actor_critic)]
    if torch.is_tensor(before) and torch.is_tensor(after):
        same = before.dtype == after.dtype and before.shape == after.shape and torch.equal(before, after)
        return [] if same else [f"{path}: tensors differ"]
    if isinstance(before, np.ndarray) and isinstance(after, np.ndarray):
        return [] if np.array_equal(before, after) else [f"{path}: arrays differ"]
    if type(before) is not type(after):
        return [f"{path}: {type(before).__name__} vs {type(after).__name__}"]
    if isinstance(before, float) and before != before and after != after:
        return []
    if hasattr(before, "__dataclass_fields__"):  # e.g. multi-policy's per-agent views: field by field
        return differences(vars(before), vars(after), path, actor_critic)
    skip = path.endswith((".run_dir", ".time", ".wall_time", ".created", ".train_dir", ".duration"))
    return [] if skip or before == after else [f"{path}: {before!r} vs {after!r}"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", default="/work/base")
    parser.add_argument("--after", default=".")
    parser.add_argument("--cases", nargs="*", default=list(CASES))
    args = parser.parse_args()
    import torch

    failed = False
    for name in args.cases:
        config, overrides = CASES[name]
        files = []
        for tree in (args.before, args.after):
            out = tempfile.mkdtemp(prefix=f"same_seed_{name}_")
            nn_dir = train(tree, config, overrides, out)
            last = sorted(f for f in os.listdir(nn_dir) if f.startswith("last_"))[-1]
            files.append(torch.load(os.path.join(nn_dir, last), map_location="cpu", weights_only=False))
        diff = [d for d in differences(*files, actor_critic=name not in OFF_POLICY)
                if "config" not in d.split(":")[0].split(".")[:3]]
        tensors = sum(1 for k in files[1]["model"])
        failed |= bool(diff)
        print(f"{name} ({config}, {EPOCHS} epochs): {'IDENTICAL' if not diff else 'DIFFERENT'} "
              f"({tensors} model tensors){'' if not diff else ': ' + '; '.join(diff[:6])}", flush=True)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
