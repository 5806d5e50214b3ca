"""``env_groups: auto`` on envpool: the env layout and rollout that step this run fastest, measured.

The layouts of the same envs give the same transitions (env i is seeded ``seed + i`` in each; the rollout
acts on the same observations in the same order: tests/smoke/test_env_groups.py), at speeds that depend on
the task and the machine (docs/benchmarks.md measures them):

- **one pool** stepped with ``step()``: the fewest calls per step. On 2 cores it is the fastest on rl_games' five
  MuJoCo YAMLs, where envpool's own threads already keep both cores busy;
- **two pools** stepped together: one pool's same-step auto-reset call can overlap the other pool's stepping;
- **two pools, pipelined**: the policy acts for one while the other steps, which pays where stepping leaves a
  core idle (more cores, or the policy on a GPU).

Two measurements choose, each with what it has to compare. At the start :func:`choose_env_layout` steps one
pool and two pools in turn for a few short rounds, synchronously, with a throwaway copy of the policy (the
act step and the env step: what a rollout step does, less the storage), and keeps the one with the lower
median seconds per step (two pools unless one is faster by :data:`MARGIN`); the torch random state is
restored afterwards, and the env restarts from the run's seed at its first reset (envpool rebuilds its pools
for a seed). With two pools, :class:`PipelineChoice` then times whole rollouts of the first epochs, stepped
together and pipelined in turn, and keeps the faster. Either way the run learns the same.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Any

import torch

from rlchain.config.params import Params
from rlchain.envs.factory import build_env
from rlchain.envs.vecenv import VecEnv
from rlchain.log import get_logger
from rlchain.models.build import build_model
from rlchain.parallel.device import resolve_device
from rlchain.policy.play import PolicySteps

log = get_logger(__name__)

MARGIN = 0.05
"""How much faster (a fraction of two pools' seconds per step) one pool must step to be chosen: two pools were
the default before and keep the pipelined rollout open, and on tasks where the two layouts differ by less
(Ant, Humanoid on 2 cores) rounds of a fraction of a second cannot tell them apart."""

ROUNDS = 7
"""Timed rounds per layout, taken in turn (a burst of load hits every layout alike)."""

ROUND_SECONDS = 0.05
"""Seconds of stepping per layout and round (rounded to whole steps, 2 to 64 of them)."""


@dataclass(frozen=True)
class Layout:
    """How many envpool pools the training envs are split into (stepped together by ``step()``)."""

    name: str
    pools: int


ONE_POOL = Layout("one pool", 1)
TWO_POOLS = Layout("two pools", 2)


def probed(env: VecEnv, params: Params) -> bool:
    """Whether ``env`` (built under ``env_groups: auto``) is one whose layout :func:`choose_env_layout` measures:
    envpool envs that auto split into groups."""
    return params.config.env_groups == "auto" and len(getattr(env, "env_groups", None) or ()) > 1


def fastest(seconds: dict[Layout, list[float]], margin: float = MARGIN) -> Layout:
    """The layout with the lower median seconds per step: ``two pools`` (which keep the pipelined rollout open,
    timed next) unless ``one pool``'s median is lower than theirs by more than ``margin`` of it."""
    one, two = (statistics.median(seconds[layout]) for layout in (ONE_POOL, TWO_POOLS))
    return ONE_POOL if one < (1.0 - margin) * two else TWO_POOLS


class _Stepper:
    """Steps one layout's env with the policy acting (the play loop's step, :class:`PolicySteps`), as a
    synchronous rollout steps it, less the storage."""

    def __init__(self, env: VecEnv, layout: Layout, model: Any, device: torch.device) -> None:
        self.layout = layout
        self.loop = PolicySteps(model, env, device, deterministic=False)

    def steps(self, count: int) -> None:
        for _ in range(count):
            self.loop.step(self.loop.masks())


def measure_layouts(steppers: list[_Stepper], rounds: int = ROUNDS,
                    round_seconds: float = ROUND_SECONDS) -> dict[Layout, list[float]]:
    """Seconds per step of each stepper's layout: 2 warm-up steps each, then ``rounds`` rounds in turn."""
    per_step = {stepper.layout: _seconds_per_step(stepper, 2) for stepper in steppers}
    seconds: dict[Layout, list[float]] = {s.layout: [] for s in steppers}
    for _ in range(rounds):
        for stepper in steppers:
            count = int(min(64, max(2, round(round_seconds / max(per_step[stepper.layout], 1e-6)))))
            seconds[stepper.layout].append(_seconds_per_step(stepper, count))
    return seconds


def _seconds_per_step(stepper: _Stepper, count: int) -> float:
    """Wall seconds per step of ``count`` steps of ``stepper``."""
    start = time.perf_counter()
    stepper.steps(count)
    return (time.perf_counter() - start) / count


def _policy(params: Params, env: VecEnv, device: torch.device) -> Any:
    """A throwaway policy of the run's network (evaluation mode), for the timing."""
    model = build_model(params, env, device)
    model.eval()
    return model


def choose_env_layout(params: Params, env: VecEnv, seed: int | None) -> Any:
    """The training env for ``env_groups: auto``: ``env`` (two envpool pools) or a one-pool env of the same
    envs, whichever :func:`measure_layouts` finds faster (see :func:`fastest`); the other is closed."""
    cfg = params.config
    device = resolve_device(cfg.device)
    one = build_env(params, cfg.num_actors, seed, runners=True, groups=1)
    try:
        with torch.random.fork_rng(devices=[device] if device.type == "cuda" else []):
            model = _policy(params, env, device)
            seconds = measure_layouts([_Stepper(one, ONE_POOL, model, device), _Stepper(env, TWO_POOLS, model, device)])
    except BaseException:
        one.close()
        raise
    layout = fastest(seconds)
    times = ", ".join(f"{lay.name} {statistics.median(t) * 1e3:.2f}" for lay, t in seconds.items())
    log.info(f"env_groups auto: {layout.name} (ms per env step with the policy: {times})")
    keep, close = (one, env) if layout is ONE_POOL else (env, one)
    close.close()
    return keep


class PipelineChoice:
    """Whether the rollout over env groups pipelines them (``send`` / ``recv``) or steps them together.

    An explicit ``env_groups`` pipelines always. Under ``auto`` the rollouts after this process's first
    (which warms up) alternate between the two, timed whole, until each way has ``trials`` timings; then the
    way with the lower median is kept.
    """

    def __init__(self, auto: bool, trials: int = 3) -> None:
        self.trials = trials
        self.calls = 0
        self.seconds: dict[bool, list[float]] = {False: [], True: []}
        self.decided: bool | None = None if auto else True

    def pipelined(self) -> bool:
        """Whether the next rollout pipelines."""
        if self.decided is not None:
            return self.decided
        return self.calls % 2 == 0  # the first (not timed) and every other trial pipeline

    def record(self, pipelined: bool, seconds: float) -> None:
        """A whole rollout took ``seconds``; decides once both ways have ``trials`` timings."""
        self.calls += 1
        if self.decided is not None or self.calls == 1:
            return
        self.seconds[pipelined].append(seconds)
        if min(len(v) for v in self.seconds.values()) < self.trials:
            return
        together, piped = (statistics.median(self.seconds[k]) for k in (False, True))
        self.decided = piped < together
        log.info(f"env_groups auto: {'pipelined' if self.decided else 'stepped together'} rollout (seconds per "
                 f"rollout: together {together:.3f}, pipelined {piped:.3f})")
