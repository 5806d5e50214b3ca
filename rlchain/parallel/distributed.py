"""torch.distributed learning under torchrun (``multi_gpu: True``): a validated launch and the syncs.

    torchrun --standalone --nnodes=1 --nproc_per_node=2 runner.py --train --file cfg.yaml

Semantics follow rl_games: every process runs the config as written -- ``num_actors`` envs of its
own, ``horizon_length`` steps, minibatches of ``minibatch_size`` -- so N processes collect N times
the batch per epoch and each optimizer step averages N minibatch gradients. Frame counters
(``max_frames``, fps, TensorBoard steps) count the frames of all ranks.

What keeps the ranks identical: parameters and optimizer state are broadcast from rank 0 at the
start (also after a resume); every optimizer step all-reduces the gradients once, flattened into
one buffer, before gradient scaling and clipping; normalizers fold the moments of every rank's
batch; the adaptive-KL schedule sees the KL averaged over ranks; the episode statistics behind
logging, ``score_to_win`` and the best checkpoint are pooled over ranks, so every rank stops at
the same epoch. Rank 0 alone writes the run folder, TensorBoard, progress and checkpoints.

A bad launch fails before any env exists, with one line: ``multi_gpu`` without torchrun,
torchrun with N > 1 processes but ``multi_gpu`` False (N unsynchronised copies of one run,
almost always a forgotten key), a LOCAL_RANK without its GPU, or ranks whose configs (or env
sizes, or resume points) differ -- the check that keeps collectives from waiting forever.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import os
import signal
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import torch
import torch.distributed as dist

from rlchain.config.errors import ConfigError
from rlchain.config.resolve import RANK_SEED_STRIDE  # rank r seeds its envs and RNGs with seed + r * this
from rlchain.errors import DistributedError
from rlchain.log import torchrun_hint
from rlchain.parallel.communicator import Communicator, merge_moments
from rlchain.registry import ALGOS

KEY = "params.config.multi_gpu"
LAUNCH_VARS = ("RANK", "WORLD_SIZE", "LOCAL_RANK", "MASTER_ADDR", "MASTER_PORT")
BARRIER_TIMEOUT = datetime.timedelta(minutes=2)  # the final barrier: every rank is at its last epoch
ROLL_CALL = "rlchain/after_timeout/"  # store keys: the ranks still running after a collective timed out
ROLL_CALL_SECONDS = 2.0  # how long a rank waits for the others' answer to the roll call


@dataclass(frozen=True)
class Launch:
    """What torchrun told this process (from its environment variables)."""

    rank: int
    world_size: int
    local_rank: int
    local_world_size: int


def read_launch(environ: Mapping[str, str], multi_gpu: bool, source: str = "",
                algo_supports: bool = True, algo: str = "") -> Launch | None:
    """Validate the launch against ``multi_gpu``; None means an ordinary single-process run.

    Raises ConfigError (one line) for ``multi_gpu`` without torchrun's variables, for torchrun with
    WORLD_SIZE > 1 while ``multi_gpu`` is False (an error rather than a warning: the N processes
    would each train, log and checkpoint their own unsynchronised copy of the run), for an
    algorithm without distributed support, and for malformed or inconsistent rank variables.
    torchrun with a single process and ``multi_gpu`` False is an ordinary run.
    """
    present = [name for name in LAUNCH_VARS if name in environ]
    world = _int_var(environ, "WORLD_SIZE", source) if "WORLD_SIZE" in environ else 1
    if not multi_gpu:
        if world > 1:
            what = f"'{algo}' does not support multi_gpu yet" if not algo_supports else "multi_gpu is False"
            raise ConfigError(source, KEY, f"launched by torchrun with WORLD_SIZE={world} but {what}: the "
                                           f"{world} processes would train {world} separate, unsynchronised "
                                           f"runs; set {KEY}=True, or start with python instead of torchrun")
        return None
    if not algo_supports:
        raise ConfigError(source, KEY, f"'{algo}' does not support multi_gpu (torchrun) yet; PPO "
                                       f"(a2c_continuous, a2c_discrete), appo, distill and grpo do")
    missing = [name for name in LAUNCH_VARS if name not in environ]
    if missing:
        got = f" (only {', '.join(present)} set)" if present else ""
        raise ConfigError(source, KEY, f"True needs the torchrun launcher: {', '.join(missing)} not set{got}; "
                                       f"start with: {torchrun_hint(source)}")
    rank = _int_var(environ, "RANK", source)
    local_rank = _int_var(environ, "LOCAL_RANK", source)
    local_world = _int_var(environ, "LOCAL_WORLD_SIZE", source) if "LOCAL_WORLD_SIZE" in environ else world
    if world < 1 or not 0 <= rank < world:
        raise ConfigError(source, KEY, f"RANK={rank} is not in [0, WORLD_SIZE={world}); launch with torchrun")
    if not 0 <= local_rank < max(local_world, 1):
        raise ConfigError(source, KEY, f"LOCAL_RANK={local_rank} is not in [0, LOCAL_WORLD_SIZE={local_world})")
    return Launch(rank, world, local_rank, local_world)


def choose_backend(device: str, local_rank: int, cuda_count: int, source: str = "") -> tuple[str, str]:
    """(backend, device) for a rank: nccl on ``cuda:LOCAL_RANK`` for a CUDA config, gloo on cpu otherwise.

    A CUDA config on a machine without CUDA trains on cpu (as a single process does, with a warning).
    """
    if not device.startswith("cuda") or cuda_count == 0:
        return "gloo", "cpu"
    if local_rank >= cuda_count:
        raise ConfigError(source, KEY, f"LOCAL_RANK={local_rank} but this node has {cuda_count} GPU(s); "
                                       f"use --nproc_per_node={cuda_count} or fewer")
    return "nccl", f"cuda:{local_rank}"


def config_fingerprint(raw: dict[str, Any], seed: int | None) -> str:
    """A short hash of the parsed config dict and the seed; ranks compare it to catch mismatched launches."""
    text = json.dumps({"config": raw, "seed": seed}, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def first_mismatch(values: list[Any]) -> int | None:
    """The first rank whose value differs from rank 0's, or None when all agree."""
    for rank, value in enumerate(values):
        if value != values[0]:
            return rank
    return None


# ----- collectives on the default group (plain functions, so models stay deep-copyable) ----------
def average_gradients(params: list[torch.Tensor]) -> None:
    """Average the gradients of ``params`` over all ranks with ONE all-reduce of a flat buffer.

    A parameter without a gradient contributes zeros, so every rank's buffer has the same layout.
    """
    world = dist.get_world_size()
    grads = [p.grad if p.grad is not None else torch.zeros_like(p) for p in params]
    flat = torch.cat([g.reshape(-1) for g in grads])
    dist.all_reduce(flat, op=dist.ReduceOp.SUM)
    flat.div_(world)
    offset = 0
    for p, g in zip(params, grads):
        n = g.numel()
        if p.grad is None:
            p.grad = g
        p.grad.copy_(flat[offset:offset + n].view_as(g))
        offset += n


def combine_moments(mean: torch.Tensor, var: torch.Tensor, count: float
                    ) -> tuple[torch.Tensor, torch.Tensor, float]:
    """The moments of every rank's batch, combined (one all_gather); identical on every rank."""
    world = dist.get_world_size()
    packed = torch.cat([torch.tensor([float(count)], dtype=mean.dtype, device=mean.device),
                        mean.reshape(-1), var.reshape(-1)])
    gathered = [torch.empty_like(packed) for _ in range(world)]
    dist.all_gather(gathered, packed)
    table = torch.stack(gathered)
    d = mean.numel()
    merged_mean, merged_var, total = merge_moments(table[:, 1:1 + d], table[:, 1 + d:], table[:, 0])
    return merged_mean.view_as(mean), merged_var.view_as(var), float(total)


def mean_over_ranks(value: float) -> float:
    """A scalar averaged over ranks, summed in rank order so every rank gets the same bits."""
    world = dist.get_world_size()
    return float(_gather_rows(torch.tensor([value], dtype=torch.float64)).sum(0)[0]) / world


def _gather_rows(row: torch.Tensor) -> torch.Tensor:
    """(world, *row.shape): every rank's ``row`` (moved to the group's device and back to cpu)."""
    device = torch.device("cuda", torch.cuda.current_device()) if dist.get_backend() == "nccl" else row.device
    row = row.to(device)
    out = [torch.empty_like(row) for _ in range(dist.get_world_size())]
    dist.all_gather(out, row)
    return torch.stack(out).cpu()


# ----- the process group --------------------------------------------------------------------
class CollectiveError(DistributedError):
    """A torch.distributed collective failed: a peer died, was killed or timed out."""


@dataclass
class Distributed(Communicator):
    """This process's place in the torchrun group, and the :class:`Communicator` that syncs through
    it; created by :func:`setup`, ended by :func:`shutdown`. Every collective it runs that fails
    raises :class:`CollectiveError` (one line naming this rank)."""

    rank: int
    world_size: int
    local_rank: int
    backend: str
    seed: int  # the run's seed, the same on every rank; each rank seeds with :attr:`rank_seed`
    local_world_size: int = 1  # processes on this node (they share its cores)
    device: str | None = None  # nccl: this rank's cuda:LOCAL_RANK, which replaces config.device (resolve)
    timeout_s: float = 300.0  # multi_gpu_timeout_s: how long a collective waits for the other ranks

    @property
    def rank_seed(self) -> int:
        """Seed of this rank's envs and RNGs: distinct per rank, equal to ``seed`` on rank 0."""
        return (self.seed + self.rank * RANK_SEED_STRIDE) % 2**32

    # ----- the Communicator ---------------------------------------------------------------------
    def average_gradients(self, params: list[torch.Tensor]) -> None:
        self._collective("gradient all-reduce", average_gradients, params)

    def combine_moments(self, mean: torch.Tensor, var: torch.Tensor, count: float
                        ) -> tuple[torch.Tensor, torch.Tensor, float]:
        return self._collective("normalizer moments", combine_moments, mean, var, count)

    def mean(self, value: float) -> float:
        return self._collective("mean over ranks", mean_over_ranks, value)

    def episode_stats(self, tracker: Any) -> dict[str, float] | None:
        """Mean reward and length (and success rate) over every rank's tracked games (None when no rank
        finished one)."""
        returns, lengths = list(tracker.finished_returns), list(tracker.finished_lengths)
        successes = list(tracker.finished_successes)
        row = torch.tensor([sum(returns), float(sum(lengths)), float(len(returns)), float(sum(successes)),
                            float(len(successes))], dtype=torch.float64)
        total = self._collective("episode statistics", _gather_rows, row).sum(0)
        if total[2] == 0:
            return None
        stats = {"reward": float(total[0] / total[2]), "length": float(total[1] / total[2])}
        if total[4] > 0:
            stats["success"] = float(total[3] / total[4])
        return stats

    def broadcast_learner(self, model: torch.nn.Module, agent: Any) -> None:
        """Rank 0's parameters and buffers (tensor broadcasts) and its agent state (optimizer, lr)."""
        self._collective("state broadcast", self._broadcast_state, model, agent)

    def gather_objects(self, obj: Any, what: str = "rank state gather") -> list[Any]:
        """Every rank's ``obj`` on every rank (``all_gather_object``; ``what`` names it if it fails)."""
        gathered: list[Any] = [None] * self.world_size
        self._collective(what, dist.all_gather_object, gathered, obj)
        return gathered

    def _collective(self, what: str, fn: Any, *args: Any) -> Any:
        """``fn(*args)``; a RuntimeError from it (the collective) becomes a one-line CollectiveError."""
        try:
            return fn(*args)
        except RuntimeError as exc:
            raise self.failure(what, exc) from exc

    def failure(self, what: str, exc: BaseException) -> CollectiveError:
        """The one-line error of a failed collective ``what``; after a timeout it names the ranks that did
        not answer (:meth:`silent_ranks`)."""
        detail = " ".join(str(exc).split())
        detail = "".join(ch for ch in detail if ch.isprintable())[:200]
        if "timed out" in detail.lower() or "timeout" in detail.lower():
            silent = self.silent_ranks()
            if silent:
                who = ", ".join(str(r) for r in silent)
                return CollectiveError(f"rank {self.rank}: rank {who} did not answer within {self.timeout_s:g} s "
                                       f"(params.config.multi_gpu_timeout_s) in the {what}: it is stopped or "
                                       f"wedged (a hung GPU or file system, a debugger); the job ends on every rank")
        return CollectiveError(f"rank {self.rank}: a collective with the other ranks failed ({what}: {detail}); "
                               f"another rank probably died or was killed: its own error above names the cause")

    def silent_ranks(self, grace: float = ROLL_CALL_SECONDS) -> list[int] | None:
        """After a collective timed out: every rank still running answers a roll call in the group's store
        (torchrun's, which outlives a stopped rank); the ranks missing after ``grace`` seconds are the ones
        that stalled. None when the store cannot be reached."""
        try:
            store = dist.distributed_c10d._get_default_store()
            store.set_timeout(datetime.timedelta(seconds=grace))
            store.set(f"{ROLL_CALL}{self.rank}", "1")
            deadline = time.monotonic() + grace
            while True:
                silent = [r for r in range(self.world_size) if not store.check([f"{ROLL_CALL}{r}"])]
                if not silent or time.monotonic() >= deadline:
                    return silent
                time.sleep(0.05)
        except Exception:  # the store itself is gone or stalled: no names, the plain message
            return None

    def check_consistent(self, env: Any, model: torch.nn.Module, state: dict[str, Any] | None) -> None:
        """Before any run folder exists: every rank has the same env count, parameters and resume point.

        Ranks that differ here would run different numbers of collectives and wait on each other forever.
        """
        facts = {"envs": int(env.num_envs), "parameters": _count(model),
                 "resume_epoch": None if state is None else int(state["epoch"]),
                 "resume_frames": None if state is None else int(state["frames"])}
        gathered = self.gather_objects(facts, "consistency check")
        bad = first_mismatch(gathered)
        if bad is not None:
            raise ConfigError("", KEY, f"rank {bad} differs from rank 0 ({gathered[bad]} vs {gathered[0]}); "
                                       f"every rank needs the same env, config and --checkpoint")

    def _broadcast_state(self, model: torch.nn.Module, agent: Any) -> None:
        with torch.no_grad():
            for tensor in model.state_dict().values():
                dist.broadcast(tensor, src=0)
        state = [agent.state_dict() if self.is_main else None]
        dist.broadcast_object_list(state, src=0)
        if not self.is_main:
            agent.load_state_dict(state[0])


def setup(params: Any, raw: dict[str, Any], seed: int | None) -> Distributed | None:
    """Validate the launch and join the process group; None for an ordinary single-process run.

    Under torchrun this also: draws the run's seed on rank 0 when none is given and shares it,
    checks every rank parsed the same config and seed, and picks a CUDA run's ``cuda:LOCAL_RANK``.
    The config itself is not changed: :func:`rlchain.config.resolve.resolve` makes the rank's run
    context from the returned group (its device, ``env_config`` seed, printing off on ranks > 0).
    """
    import secrets


    cfg = params.config
    trainer_class = ALGOS.get(params.algo.name)
    supports = bool(getattr(trainer_class, "supports_distributed", False))  # the Algorithm protocol's flag
    launch = read_launch(os.environ, bool(getattr(cfg, "multi_gpu", False)), params.source, supports,
                         params.algo.name)
    if launch is None:
        return None
    backend, device = choose_backend(cfg.device, launch.local_rank,
                                     torch.cuda.device_count() if torch.cuda.is_available() else 0, params.source)
    if backend == "nccl":
        torch.cuda.set_device(launch.local_rank)
    timeout_s = float(getattr(cfg, "multi_gpu_timeout_s", 300.0))
    dist.init_process_group(backend, rank=launch.rank, world_size=launch.world_size,
                            timeout=datetime.timedelta(seconds=timeout_s))
    try:
        fingerprint = config_fingerprint(raw, seed)
        gathered: list[Any] = [None] * launch.world_size
        dist.all_gather_object(gathered, fingerprint)
        bad = first_mismatch(gathered)
        if bad is not None:
            raise ConfigError(params.source, KEY, f"rank {bad} parsed a different config or seed than rank 0 "
                                                  f"(hash {gathered[bad]} vs {gathered[0]}); every rank must "
                                                  f"get the same file, overrides and --seed")
        shared = [seed if seed is not None else secrets.randbelow(2**31)]
        dist.broadcast_object_list(shared, src=0)
    except BaseException:
        dist.destroy_process_group()
        raise
    # the per-rank config (device, env_config seed, printing) is rlchain.config.resolve.resolve's, from this
    return Distributed(launch.rank, launch.world_size, launch.local_rank, backend, int(shared[0]),
                       launch.local_world_size, device if backend == "nccl" else None, timeout_s)


def shutdown(group: Distributed | None, clean: bool) -> None:
    """Leave the group: destroy_process_group, after a barrier when the run ended by its own stop
    condition (every rank stops at the same epoch). No barrier after an error or a signal: a rank
    that died never arrives, and one still inside an update would pair the barrier with its
    all-reduce. A rank missing the barrier for BARRIER_TIMEOUT is a DistributedError naming it."""
    if group is None or not dist.is_initialized():
        return
    if not clean and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # torchrun's SIGTERM must not hide the error being raised
    try:
        if clean and group.backend == "gloo":
            dist.monitored_barrier(timeout=BARRIER_TIMEOUT)
        elif clean:
            dist.barrier()
    except RuntimeError as exc:
        raise DistributedError(f"rank {group.rank}: the ranks did not finish together: "
                               f"{' '.join(str(exc).split())[:200]}") from None
    finally:
        dist.destroy_process_group()


def collective_failure(group: Distributed | None, exc: BaseException) -> DistributedError | None:
    """The one-line error a run under torchrun ends with when ``exc`` came from a collective (a
    :class:`CollectiveError`, raised by :class:`Distributed`'s own collectives, or torch's
    ``DistError`` family from anywhere else); None for any other exception or a single process."""
    if group is None:
        return None
    if isinstance(exc, CollectiveError):
        return exc
    if isinstance(exc, dist.DistError):
        return group.failure(type(exc).__name__, exc)
    return None


def _count(model: torch.nn.Module) -> int:
    return sum(p.numel() for p in model.parameters())


def _int_var(environ: Mapping[str, str], name: str, source: str) -> int:
    try:
        return int(environ[name])
    except ValueError:
        raise ConfigError(source, KEY, f"environment variable {name}={environ[name]!r} is not an integer") from None
