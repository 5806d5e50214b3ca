"""Steps per second of env backends, alone and inside rlchain's PPO loop, in one table.

    python benchmarks/throughput/throughput.py                       # the default cases below
    python benchmarks/throughput/throughput.py --cases torch:TorchReacher8-v0:4096 gymnasium:Pendulum-v1:64
    python benchmarks/throughput/throughput.py --seconds 5 --threads 1 --json out.json
    python benchmarks/throughput/throughput.py --cases envpool:Ant-v4:64:benchmarks/rl_games_configs/ant_envpool.yaml \
        --env-groups 1 2 --rl-games-python /work/rlg-venv/bin/python

A case is ``BACKEND:ENV:NUM_ENVS[:CONFIG]``: BACKEND is ``torch`` (a registered tensor env),
``gymnasium`` (a gymnasium id with vecenv_type auto: the native vector env when there is one)
or ``envpool``; CONFIG is a yaml (default: the shipped config for ENV, see ``CONFIGS``) whose
network and PPO settings are used, with ``num_actors`` set to NUM_ENVS and ``minibatch_size``
scaled to keep the same number of minibatches per epoch. For each case it measures

- env-only: ``env.step`` with pre-drawn random actions (tensors on the env's device for tensor
  envs, numpy arrays otherwise) -- the ceiling;
- rollout: ``PPO.rollout`` (policy inference, env step, storage), no update;
- train: ``_rollout`` + ``_learn`` (GAE and the PPO update), i.e. what a training run does
  minus logging and checkpoints;

and prints steps/s for each plus rollout/env and train/env. ``--env-groups 1 2`` measures envpool
cases once per ``env_groups`` value (1: synchronous rollout; 2: two env groups stepping in the
background while the policy acts for the other, see ``EnvpoolVecEnv``; auto: the layout the trainer measures
fastest at the start, its trial rollouts run before the timing; the grp column shows the layout: 1 / 2t / 2p
for one pool / two stepped together / two pipelined, a1 / a2t / a2p where auto chose it); env-only is always
the synchronous step of all envs.
``--rl-games-python PY`` (rl_games 1.6.5) and ``--rl-games2-python PY``
(its main branch, 2.0) add rl_games' training steps/s on the same YAML and NUM_ENVS (``rl_games_driver.py`` for
``--rl-games-epochs`` epochs, median "fps total" of the epochs after the first, ``--rl-games-threads`` torch
threads (default 1, set through rl_games' own ``params.torch_threads``: rl_games sets torch's thread count itself,
to min(4, cores) when the YAML has none, whatever OMP_NUM_THREADS says), torch.compile off;
``--rl-games-compile off config`` adds a column with the YAML's or rl_games' default compile setting).
Torch cases reach rl_games through its own vecenv API (``rl_games_tensor_env.py``), as an Isaac Lab env does::

    python benchmarks/throughput/throughput.py --cases torch:TorchCartPole-v0:4096 torch:TorchPendulum-v0:4096 \
        --rl-games-python /work/rlg-venv/bin/python --rl-games2-python /work/rlg2-venv/bin/python

Torch threads are set as the Runner
sets them (the config's ``torch_threads``, else half the cores, at most 4) unless ``--threads``;
``--update-threads 1 2`` measures once per thread count of the PPO update (``params.update_threads``);
the ``thr`` column is rollout/update threads. env-only is measured once per case.
``--plans auto 1/1`` measures once per thread plan (``auto``: the Runner's plan, which adapts to the
load; ``R/U``: exactly R rollout and U update threads, not adapted), and ``--busy 0 1`` once per
count of busy-looping background processes (a loaded machine, made on purpose), so "the thread plan
never loses to one thread, loaded or idle" is one run::

    python benchmarks/throughput/throughput.py --cases envpool:HalfCheetah-v4:64 --plans auto 1/1 --busy 0 1

``--variants LABEL=KEY=VALUE[,KEY=VALUE...]`` measures each case once per set of config overrides
(``base=`` for none), with the first variant as the base of the ``x base`` column, and the warm-up
epoch's seconds (compilation happens there) in ``warmup s``. A compiled variant on a CPU with an adaptive thread
plan warms up once per thread count the plan may use (inductor builds CPU kernels per count), so that no
compilation lands in the timed window::

    python benchmarks/throughput/throughput.py --cases torch:TorchPendulum-v0:4096 --variants base= \
        bf16=params.config.mixed_precision=bf16 \
        bf16+compile=params.config.mixed_precision=bf16,params.config.compile_update=True

The load average is printed too: other processes on the machine skew every number.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing
import os
import sys
import time
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain first (tree_compare.py times two checkouts)
    sys.path.insert(0, ROOT)

from rlchain import Runner  # noqa: E402
from rlchain.algos.ppo.ppo import PPO  # noqa: E402
from rlchain.models.build import build_env, build_model, resolve_device  # noqa: E402
from rlchain.parallel.memory import tune_malloc  # noqa: E402
from rlchain.parallel.threads import ThreadPlan, for_env, plan_threads  # noqa: E402
from rlchain.runs.logging import TrainLogger  # noqa: E402
from rlchain.training.loop import Loop  # noqa: E402

CONFIG_DIR = os.path.join(ROOT, "rlchain", "configs")
CONFIGS = {
    "TorchCartPole-v0": "ppo_torch_cartpole.yaml",
    "TorchPendulum-v0": "ppo_torch_pendulum.yaml",
    "TorchReacher8-v0": "ppo_torch_reacher8.yaml",
    "CartPole-v1": "ppo_cartpole.yaml",
    "Pendulum-v1": "ppo_pendulum.yaml",
    "HalfCheetah-v4": "ppo_halfcheetah.yaml",
}
DEFAULT_CASES = ["torch:TorchCartPole-v0:1024", "torch:TorchCartPole-v0:4096", "gymnasium:CartPole-v1:64",
                 "envpool:HalfCheetah-v4:64"]


@dataclass
class Row:
    backend: str
    env: str
    num_envs: int
    env_sps: float
    rollout_sps: float
    train_sps: float
    threads: int
    config: str
    groups: int | str = 1
    peers: dict[str, float | None] = field(default_factory=dict)  # rl_games settings' train steps/s
    update_threads: int = 1
    plan: str = "auto"
    busy: int = 0
    variant: str = "base"
    warmup_s: float = 0.0  # the first rollout + update (compiling, with compile_update)
    base_train_sps: float | None = None  # the first variant's, same case, plan and load

    @property
    def rollout_ratio(self) -> float:
        return self.rollout_sps / self.env_sps

    @property
    def train_ratio(self) -> float:
        return self.train_sps / self.env_sps


def parse_case(spec: str) -> tuple[str, str, int, str]:
    parts = spec.split(":")
    if len(parts) not in (3, 4) or parts[0] not in ("torch", "gymnasium", "envpool"):
        raise SystemExit(f"bad case '{spec}': expected BACKEND:ENV:NUM_ENVS[:CONFIG], BACKEND torch, "
                         f"gymnasium or envpool")
    backend, env, num = parts[0], parts[1], int(parts[2])
    if len(parts) == 4:
        config = parts[3]
    elif env in CONFIGS:
        config = os.path.join(CONFIG_DIR, CONFIGS[env])
    else:
        raise SystemExit(f"no default config for '{env}'; give one: {spec}:path/to/config.yaml")
    return backend, env, num, config


def overrides(backend: str, env: str, num_envs: int, raw_config: dict, device: str) -> list[str]:
    """num_actors, minibatch_size (same minibatch count), env selection and device."""
    cfg = raw_config["params"]["config"]
    horizon = int(cfg.get("horizon_length", 32))
    batch_cfg = horizon * int(cfg.get("num_actors", 8))
    minibatch_cfg = cfg.get("minibatch_size") or int(cfg["minibatch_size_per_env"]) * int(cfg["num_actors"])
    count = max(1, batch_cfg // int(minibatch_cfg))
    batch = horizon * num_envs
    minibatch = batch // count if batch % count == 0 else batch
    out = ["params.config.print_stats=false", f"params.config.num_actors={num_envs}",
           f"params.config.minibatch_size={minibatch}", "params.config.minibatch_size_per_env=null",
           f"params.config.device={device}"]
    if backend == "torch":
        out += [f"params.config.env_name={env}", f"params.config.env_config.device={device}"]
    elif backend == "gymnasium":
        out += [f"params.config.env_name={env}", "params.config.vecenv_type=auto"]
    else:
        out += ["params.config.env_name=envpool", f"params.config.env_config.env_name={env}"]
    return out


def random_actions(env: Any, count: int, rng: np.random.Generator) -> list[Any]:
    """``count`` batches of uniformly random actions in the form ``env.step`` takes."""
    space, n = env.action_space, env.num_envs
    if hasattr(space, "n"):
        batches = [rng.integers(0, int(space.n), n) for _ in range(count)]
    else:
        batches = [rng.uniform(space.low, space.high, (n, *space.shape)).astype(np.float32) for _ in range(count)]
    if getattr(env, "is_tensor_env", False):
        return [torch.as_tensor(b, device=env.device) for b in batches]
    return batches


def sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def timed(fn: Any, steps_per_call: int, seconds: float, device: torch.device, min_calls: int = 3) -> float:
    """Call ``fn`` for at least ``seconds`` (and ``min_calls`` times); return steps per second."""
    calls = 0
    sync(device)
    start = time.perf_counter()
    while True:
        fn()
        calls += 1
        if calls >= min_calls and time.perf_counter() - start >= seconds:
            break
    sync(device)
    return calls * steps_per_call / (time.perf_counter() - start)


def case_runner(backend: str, env_name: str, num_envs: int, config: str, device_name: str,
                extra: list[str] | tuple[str, ...] = ()) -> Runner:
    """A Runner loaded with ``config`` and the case's :func:`overrides` (then ``extra`` ones) on top."""
    raw = Runner().load(config).raw
    return Runner().load(config, overrides(backend, env_name, num_envs, raw, device_name) + list(extra))


def measure(backend: str, env_name: str, num_envs: int, config: str, seconds: float, threads: int | None,
            device_name: str, groups: int | str = 1, update_threads: int | None = None,
            env_sps: float | None = None, fixed: bool = False, sets: tuple[str, ...] = ()) -> Row:
    """One row: env-only (unless ``env_sps`` is given), rollout and train steps/s of one case, with the
    config overrides ``sets`` (a variant) on top of the case's."""
    extra = ([f"params.config.env_groups={groups}"] if backend == "envpool" else []) + list(sets)
    runner = case_runner(backend, env_name, num_envs, config, device_name, extra)
    params = runner.params
    if fixed:  # exactly these counts, whatever else runs (no adaptation to the load)
        plan = ThreadPlan(threads or 1, update_threads or threads or 1)
    else:
        plan = plan_threads(threads or params.torch_threads, update_threads or params.update_threads,
                            params.config.device)
    if plan is not None:
        plan.apply()
    tune_malloc(params.malloc)  # as training does (once per process: a later 'default' cannot undo it)
    torch.manual_seed(0)
    device = resolve_device(params.config.device)
    env = build_env(params, num_envs, 0)
    if not fixed:  # as the Runner does: a tensor env's rollout takes the update's threads
        plan = for_env(plan, env, threads or params.torch_threads)
    try:
        env_device = getattr(env, "device", torch.device("cpu"))
        env.reset(seed=0)
        actions = random_actions(env, 16, np.random.default_rng(0))
        state = {"i": 0}

        def env_steps() -> None:
            for _ in range(10):
                env.step(actions[state["i"] % len(actions)])
                state["i"] += 1

        if env_sps is None:
            env_steps()  # warm-up
            env_sps = timed(env_steps, 10 * num_envs, seconds, env_device)
        if backend == "envpool" and groups != 1:  # the training envs, in env groups (auto: as measured)
            env.close()
            env = PPO.build_training_env(params, 0)

        model = build_model(params, env, device)
        loop = Loop(params, PPO, env, model, device, None, TrainLogger(None, False), 0, runner.raw)
        loop.threads = plan
        ppo, ctx = loop.algorithm, loop.ctx  # the algorithm the loop holds, and the run context it gets
        ppo.collector.place(torch.as_tensor(env.reset(seed=0), device=device))
        start = time.perf_counter()
        ppo.collector.rollout()
        with ctx.update_phase():
            ppo.update()  # warm-up (and compilation)
        while len(ctx.spec.groups or ()) > 1 and ppo.collector.pipeline_choice.decided is None:  # auto, 2 pools
            ppo.collector.rollout()
        if backend == "envpool":
            groups = layout_label(env, ppo, params.config.env_groups == "auto")
        if plan is not None and plan.adaptive and (params.config.compile_update or params.config.torch_compile):
            # inductor builds its CPU kernels once per torch thread count, and an adaptive plan may run a phase
            # at any count from 1 up to its own: compile them all here, not inside the timed window
            for count in range(1, max(plan.rollout, plan.update) + 1):
                torch.set_num_threads(count)
                ppo.collector.rollout()
                ppo.update()
            plan.apply()
        sync(device)
        warmup_s = time.perf_counter() - start
        batch = params.config.horizon_length * num_envs
        rollout_sps = timed(ppo.collector.rollout, batch, seconds, device)

        def train_epoch() -> None:
            ppo.collector.rollout()
            with ctx.update_phase():
                ppo.update()

        train_sps = timed(train_epoch, batch, seconds, device)
    finally:
        env.close()
    return Row(backend, env_name, num_envs, env_sps, rollout_sps, train_sps, torch.get_num_threads(),
               os.path.relpath(config, ROOT), groups if backend == "envpool" else 1,
               update_threads=plan.update if plan is not None else torch.get_num_threads(), warmup_s=warmup_s)


@dataclass(frozen=True)
class Peer:
    """One rl_games setting measured beside rlchain: its venv's python and its torch_compile setting."""

    label: str  # the table's column, e.g. "rlg1.6.5" or "rlg2.0+compile"
    python: str
    compile: str  # "off", or "config": the YAML's torch_compile, rl_games' default (on) where it has none


def rl_games_fps(python: str, config: str, env_name: str, num_envs: int, epochs: int, backend: str = "envpool",
                 compile: str = "off", device: str = "cpu", threads: int = 1) -> float | None:
    """rl_games' median training fps ("fps total": rollout and update) over epochs 2..``epochs`` on ``config``
    with ``num_envs`` actors (minibatch_size scaled as rlchain's rows scale it) and ``threads`` torch threads
    (rl_games sets its own count from ``params.torch_threads``, min(4, cores) when unset, whatever
    OMP_NUM_THREADS says, so the driver passes it); torch envs through rl_games' vecenv API
    (rl_games_tensor_env.py). None when the run fails, or when the YAML's env is not ``env_name`` (rlchain's rows
    override it; rl_games reads it from the YAML)."""
    import re
    import statistics
    import subprocess
    import tempfile

    import yaml

    with open(config) as fh:
        cfg = yaml.safe_load(fh)["params"]["config"]
    yaml_env = cfg.get("env_config", {}).get("env_name") if backend == "envpool" else cfg.get("env_name")
    if yaml_env != env_name:  # rl_games reads the env from the YAML only
        print(f"rl_games not run on {config}: its env is {yaml_env}, the case's is {env_name}", flush=True)
        return None
    driver = os.path.join(ROOT, "benchmarks", "peers", "rl_games_driver.py")
    count = str(threads)
    cmd = [python, driver, "--file", os.path.abspath(config), "--max-epochs", str(epochs), "--torch-compile",
           compile, "--num-actors", str(num_envs), "--device", device, "--torch-threads", count]
    if backend == "torch":
        cmd.append("--tensor-env")
    env = {**os.environ, "OMP_NUM_THREADS": count, "MKL_NUM_THREADS": count}  # 1: rl_games at its best on 2 cores
    with tempfile.TemporaryDirectory() as cwd:
        try:
            proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, env=env)
        except OSError as exc:  # e.g. a --rl-games-python that is not there
            print(f"rl_games not run on {config}: {python}: {exc.strerror}", flush=True)
            return None
    values = [float(v) for v in re.findall(r"fps total: ([0-9.]+)", proc.stdout)]
    if proc.returncode != 0 or len(values) < 2:
        print(f"rl_games run on {config} failed (exit {proc.returncode}): {proc.stderr.strip()[-300:]}", flush=True)
        return None
    return statistics.median(values[1:])


def layout_label(env: Any, ppo: Any, auto: bool) -> str:
    """The envpool layout measured: 1 (one pool), Nt (N pools stepped together), Np (N pools pipelined);
    prefixed a where ``env_groups: auto`` chose it."""
    pools = len(getattr(env, "pools", ())) or 1
    label = "1" if pools == 1 else f"{pools}{'p' if ppo.collector.pipeline_choice.decided else 't'}"
    return f"a{label}" if auto else label


def parse_groups(spec: str) -> int | str:
    """An ``--env-groups`` value: auto or an int >= 1."""
    if spec == "auto":
        return spec
    try:
        return int(spec)
    except ValueError:
        raise SystemExit(f"bad --env-groups value '{spec}': expected auto or an int") from None


def parse_threads(spec: str) -> int:
    """A ``--rl-games-threads`` value: an int >= 1 (rl_games reads 0 as torch's default count)."""
    try:
        value = int(spec)
    except ValueError:
        value = 0
    if value < 1:
        raise SystemExit(f"bad --rl-games-threads value '{spec}': expected an int >= 1")
    return value


def parse_plan(spec: str) -> tuple[str, int | None, int | None]:
    """'auto' -> the Runner's plan; 'R/U' -> exactly R rollout threads and U update threads."""
    if spec == "auto":
        return spec, None, None
    try:
        rollout, update = (int(v) for v in spec.split("/"))
    except ValueError:
        raise SystemExit(f"bad plan '{spec}': expected auto or R/U, e.g. 1/1 or 1/2") from None
    return spec, rollout, update


def parse_variant(spec: str) -> tuple[str, tuple[str, ...]]:
    """'LABEL=KEY=VALUE[,KEY=VALUE...]' -> (LABEL, overrides); 'LABEL=' -> no overrides."""
    label, sep, sets = spec.partition("=")
    overrides = tuple(s for s in sets.split(",") if s)
    if not sep or not label or any("=" not in s for s in overrides):
        raise SystemExit(f"bad variant '{spec}': expected LABEL= or LABEL=KEY=VALUE[,KEY=VALUE...], "
                         f"e.g. bf16=params.config.mixed_precision=bf16")
    return label, overrides


def _spin() -> None:
    """A busy loop: one core's worth of load from another program."""
    while True:
        pass


@contextlib.contextmanager
def busy_processes(count: int) -> Any:
    """``count`` busy-looping processes for the duration of the block (a loaded machine, on purpose)."""
    procs = [multiprocessing.Process(target=_spin, daemon=True) for _ in range(count)]
    for proc in procs:
        proc.start()
    try:
        yield
    finally:
        for proc in procs:
            proc.terminate()
            proc.join()


def table(rows: list[Row]) -> str:
    labels = list(dict.fromkeys(label for r in rows for label in r.peers))
    head = (f"{'backend':<10} {'env':<18} {'envs':>6} {'grp':>4} {'env-only sps':>13} {'rollout sps':>12} "
            f"{'train sps':>11} {'rollout/env':>11} {'train/env':>9} {'thr':>5} {'plan':>5} {'busy':>4}"
            f" {'variant':>14} {'warmup s':>8} {'x base':>6}"
            + "".join(f" {label + ' sps':>18} {'train/' + label:>20}" for label in labels))
    lines = [head, "-" * len(head)]
    for r in rows:
        x_base = "-" if r.base_train_sps is None else f"{r.train_sps / r.base_train_sps:.2f}"
        peer = ""
        for label in labels:
            sps = r.peers.get(label)
            peer += f" {'-':>18} {'-':>20}" if sps is None else f" {sps:>18,.0f} {r.train_sps / sps:>20.2f}"
        lines.append(f"{r.backend:<10} {r.env:<18} {r.num_envs:>6} {str(r.groups):>4} {r.env_sps:>13,.0f} "
                     f"{r.rollout_sps:>12,.0f} {r.train_sps:>11,.0f} {r.rollout_ratio:>11.3f} "
                     f"{r.train_ratio:>9.3f} {f'{r.threads}/{r.update_threads}':>5} {r.plan:>5} {r.busy:>4}"
                     f" {r.variant:>14} {r.warmup_s:>8.1f} {x_base:>6}{peer}")
    return "\n".join(lines)


def rl_games_peers(args: argparse.Namespace) -> list[Peer]:
    """The rl_games settings to measure beside rlchain: each version given a python, each compile setting."""
    versions = [("rlg1.6.5", args.rl_games_python), ("rlg2.0", args.rl_games2_python)]
    return [Peer(label + ("" if compile == "off" else "+compile"), python, compile)
            for label, python in versions if python for compile in args.rl_games_compile]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", nargs="+", default=None, help=f"BACKEND:ENV:NUM_ENVS[:CONFIG] (default: "
                                                              f"{' '.join(DEFAULT_CASES)})")
    ap.add_argument("--seconds", type=float, default=3.0, help="time per measurement (default 3)")
    ap.add_argument("--threads", type=int, default=None, help="torch threads (default: as the Runner sets them)")
    ap.add_argument("--update-threads", type=int, nargs="+", default=[None],
                    help="measure once per update_threads value (threads during the PPO update; default: "
                         "the config's, else the same as --threads)")
    ap.add_argument("--device", default="cpu", help="training device, and the device of tensor envs")
    ap.add_argument("--json", default=None, help="also write the rows to this file")
    ap.add_argument("--env-groups", type=parse_groups, nargs="+", default=[1],
                    help="envpool cases: measure once per env_groups value, auto or an int (default: 1)")
    ap.add_argument("--rl-games-python", default=None,
                    help="python of a venv with rl_games 1.6.5: add its training fps on the same YAML and envs")
    ap.add_argument("--rl-games2-python", default=None,
                    help="python of a venv with rl_games' main branch (2.0, built from source): the same")
    ap.add_argument("--rl-games-compile", nargs="+", choices=("off", "config"), default=["off"],
                    help="rl_games' torch_compile: off (its best on a small CPU), config (the YAML's, else "
                         "rl_games' default: on); one column per setting and version (default off)")
    ap.add_argument("--rl-games-epochs", type=int, default=12, help="rl_games epochs per case (default 12)")
    ap.add_argument("--rl-games-threads", type=parse_threads, default=1,
                    help="rl_games' torch threads (params.torch_threads; default 1, its best beside envpool on a small "
                         "CPU; a tensor env steps on torch's threads, so measure 2 there too)")
    ap.add_argument("--plans", nargs="+", default=None,
                    help="thread plans to measure, 'auto' (the Runner's) or R/U (rollout/update threads); "
                         "replaces --threads / --update-threads")
    ap.add_argument("--variants", nargs="+", default=["base="],
                    help="measure once per LABEL=KEY=VALUE[,KEY=VALUE...] set of config overrides (LABEL= for "
                         "none); the first is the base of the 'x base' column")
    ap.add_argument("--busy", type=int, nargs="+", default=[0],
                    help="measure once per count of busy-looping background processes (default 0)")
    args = ap.parse_args(argv)
    plans = [parse_plan(p) for p in args.plans] if args.plans else [
        ("auto" if args.threads is None and u is None else f"{args.threads or '-'}/{u or '-'}", args.threads, u)
        for u in args.update_threads]

    variants = [parse_variant(v) for v in args.variants]
    cases = args.cases or DEFAULT_CASES
    rows = []
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    for spec in cases:
        backend, env, num, config = parse_case(spec)
        if backend == "envpool":
            try:
                import envpool  # noqa: F401
            except ImportError:
                print(f"skipping {spec}: envpool is not installed", flush=True)
                continue
        peers = {}
        for peer in rl_games_peers(args):
            print(f"{peer.label} on {spec} ...", flush=True)
            peers[peer.label] = rl_games_fps(peer.python, config, env, num, args.rl_games_epochs, backend,
                                             peer.compile, args.device, args.rl_games_threads)
        env_sps = None  # env-only is measured once per case (idle): every row's ratios share one ceiling
        for busy in args.busy:
            with busy_processes(busy):
                for groups in (args.env_groups if backend == "envpool" else [1]):
                    for name, threads, update_threads in plans:
                        base_sps = None
                        for label, sets in variants:
                            print(f"measuring {spec} env_groups={groups} plan={name} busy={busy} variant={label} "
                                  f"...", flush=True)
                            row = measure(backend, env, num, config, args.seconds, threads, args.device, groups,
                                          update_threads, env_sps, fixed=name != "auto" and bool(args.plans),
                                          sets=sets)
                            row.peers, row.plan, row.busy, row.variant = peers, name, busy, label
                            row.base_train_sps = base_sps
                            base_sps = base_sps or row.train_sps
                            env_sps = row.env_sps
                            rows.append(row)
    load_after = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print()
    print(table(rows))
    print(f"\n{os.cpu_count()} cores, torch {torch.__version__}, device {args.device}, load average "
          f"{load:.2f} before / {load_after:.2f} after (anything else running skews the numbers)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump([asdict(r) | {"rollout_over_env": r.rollout_ratio, "train_over_env": r.train_ratio}
                       for r in rows], fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
