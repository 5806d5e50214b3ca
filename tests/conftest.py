"""Shared test helpers: repository paths and a tiny config factory."""

import copy
import importlib.util
import os
import resource
import sys
import time

import pytest
import torch

from rlchain import Runner
from rlchain.algos.ppo.ppo import PPO
from rlchain.models.build import build_env, build_model
from rlchain.registry import scoped_registrations
from rlchain.runs.logging import TrainLogger
from rlchain.training.loop import Loop

# One intra-op thread, as the Runner sets on a 2-core machine: tests that build models directly
# (not through the Runner) would otherwise spin 2 OpenMP threads beside envpool / Ray workers.
torch.set_num_threads(1)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIGS = os.path.join(ROOT, "rlchain", "configs")
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

BASE = {
    "params": {
        "seed": 1,
        "algo": {"name": "a2c_discrete"},
        "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [16]}},
        "config": {"name": "t", "env_name": "CartPole-v1", "device": "cpu", "num_actors": 4,
                   "horizon_length": 8, "minibatch_size": 16, "mini_epochs": 1},
    }
}


def installed(*modules: str) -> pytest.MarkDecorator:
    """A skip mark for a test module that needs ``modules`` (top-level names), decided without importing them:
    ``pytest.importorskip`` at module level imports the package when the file is collected, and every pytest
    process collects every file (jax with brax or mujoco_playground: ~6-7 s of CPU each, paid again by each
    xdist worker and by the learning tier, which runs none of these tests). The tests import it when they run."""
    missing = [name for name in modules if importlib.util.find_spec(name) is None]
    return pytest.mark.skipif(bool(missing), reason=f"needs {', '.join(missing)} (not installed)")


@pytest.fixture
def scoped_registries():
    """What the test registers (algos, models, networks, envs, vecenv types, log writers)
    is gone after it; what it replaced or unregistered is back."""
    with scoped_registrations():
        yield


@pytest.fixture
def base_config():
    """A fresh small valid CartPole config dict."""
    return copy.deepcopy(BASE)


@pytest.fixture(autouse=True)
def one_thread_for_learning_tests(request, monkeypatch):
    """A learning test (marked slow) trains and plays on one torch thread, rollout and update alike, unless its
    config names its own counts: the thread plan otherwise follows the machine's load (the update takes the
    cores idle at the time), and with it the float rounding, so a same-seed run could pass on an idle machine
    and fail on a busy one. Pinned, two learning tests run side by side (pytest -n 2) as they run alone."""
    if request.node.get_closest_marker("slow") is None:
        yield
        return
    import rlchain.runner
    from rlchain.parallel.threads import set_threads

    def pinned(torch_threads, update_threads, device, *args, **kwargs):
        return set_threads(torch_threads or 1, update_threads or 1, device, *args, **kwargs)

    monkeypatch.setattr(rlchain.runner, "set_threads", pinned)
    torch.set_num_threads(1)
    yield


_SEED = os.environ.get("RLCHAIN_LEARNING_SEED")
"""A seed every run a learning test trains (``Runner.train``) takes in place of its own: tests/tools/seed_spread.py
runs the learning tests on other seeds with it."""
_RESULTS = os.environ.get("RLCHAIN_LEARNING_RESULTS")
"""A file to append, as a JSON line, what each run a learning test trains ended with (the seed, frames, epochs,
why it stopped, its rewards): how many frames a run took to its score, which a pass or fail does not say."""


def _reward_curve(run_dir: str) -> list:
    """[frames, mean episode reward] of each epoch a run logged (the rewards/step scalar; [] without one): the
    frames a lower threshold would have taken, read off a run that went on to its own."""
    from rlchain.compare.runs import CompareError, read_curves

    try:
        curve = read_curves(run_dir, ["rewards/step"]).get("rewards/step")
    except (CompareError, OSError):
        return []
    return [] if curve is None else [[int(f), round(float(v), 4)] for f, v in zip(curve.frames, curve.values)]


@pytest.fixture(autouse=True)
def learning_seed_and_results(request, monkeypatch):
    """With ``RLCHAIN_LEARNING_SEED`` or ``RLCHAIN_LEARNING_RESULTS`` set, a learning test's runs take that seed
    and report how they ended (tests/tools/seed_spread.py); otherwise nothing changes."""
    if (_SEED is None and _RESULTS is None) or request.node.get_closest_marker("slow") is None:
        yield
        return
    import inspect
    import json

    train = Runner.train
    signature = inspect.signature(train)

    def reported(self, *args, **kwargs):
        bound = signature.bind(self, *args, **kwargs)
        if _SEED is not None:
            bound.arguments["seed"] = int(_SEED)
        seed = bound.arguments.get("seed")
        result = train(*bound.args, **bound.kwargs)
        if _RESULTS:
            with open(_RESULTS, "a") as f:
                f.write(json.dumps({"test": request.node.nodeid, "seed": seed if seed is not None else self.params.seed,
                                    "frames": result.frames, "epoch": result.epoch, "stop": result.stop_reason,
                                    "mean_reward": result.mean_reward, "best_reward": result.best_reward,
                                    "seconds": round(result.seconds, 1), "curve": _reward_curve(result.run_dir)})
                        + "\n")
        return result

    play = Runner.play

    def played(self, *args, **kwargs):
        result = play(self, *args, **kwargs)
        if _RESULTS:
            with open(_RESULTS, "a") as f:
                f.write(json.dumps({"test": request.node.nodeid, "played": result.mean_reward}) + "\n")
        return result

    monkeypatch.setattr(Runner, "train", reported)
    monkeypatch.setattr(Runner, "play", played)
    yield


_TIMES = os.environ.get("RLCHAIN_TEST_TIMES")
"""A file to append each test's wall and CPU seconds to, as it ends: the budget of a run on a loaded machine,
where wall time says more about the other programs than about the test (CPU time: this process and the
children it waited for; a test on two threads counts both)."""


def _cpu() -> float:
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _live_children_cpu() -> float:
    """CPU seconds of this process's running children and of what they waited for (a fork server's commands)."""
    import glob

    total, tick = 0.0, os.sysconf("SC_CLK_TCK")
    for path in glob.glob(f"/proc/{os.getpid()}/task/*/children"):
        try:
            with open(path) as fh:
                pids = fh.read().split()
        except OSError:
            continue
        for pid in pids:
            try:
                with open(f"/proc/{pid}/stat") as fh:
                    fields = fh.read().rsplit(")", 1)[1].split()
                total += sum(int(value) for value in fields[11:15]) / tick  # utime stime cutime cstime
            except (OSError, IndexError, ValueError):
                pass
    return total


if _TIMES:
    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(item, nextitem):
        wall, cpu, live = time.perf_counter(), _cpu(), _live_children_cpu()
        yield
        live = max(_live_children_cpu() - live, 0.0)  # a child that ended in between is in _cpu() instead
        with open(_TIMES, "a") as f:
            f.write(f"{time.perf_counter() - wall:.2f}\t{_cpu() - cpu + live:.2f}\t{item.nodeid}\n")


def _signal_state() -> tuple:
    """SIGINT/SIGTERM handlers and the main thread's blocked signals: what a run may change only for its duration."""
    import signal

    handlers = tuple(signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM))
    return handlers, frozenset(signal.pthread_sigmask(signal.SIG_BLOCK, []))


def pytest_configure(config):
    """JAX's persistent compile cache for the whole test run, in pytest's cache folder (``.pytest_cache``, which git
    ignores; none with ``-p no:cacheprovider``): a Brax or Playground env's reset and step (10-30 s of CPU to
    compile) compile once per checkout and JAX version, and the next run, its xdist workers and the other tier load
    them. Set in the environment before any test imports jax (jax reads it at import), so the tests' subprocesses
    share it; a ``JAX_COMPILATION_CACHE_DIR`` of the caller's own wins. Only the test run: rlchain sets no cache."""
    cache = getattr(config, "cache", None)
    if cache is not None and "JAX_COMPILATION_CACHE_DIR" not in os.environ:
        os.environ["JAX_COMPILATION_CACHE_DIR"] = str(cache.mkdir("jax-compile-cache"))


def pytest_collection_finish(session):
    """torch imports torch._dynamo lazily, at a process's first optimizer (seconds of CPU, tens under load). A
    timeout (pytest-timeout's signal, a test's own alarm) that goes off inside that import leaves it
    half-imported for the rest of the process, and every later torch.compile there fails ("module
    'torch._dynamo.convert_frame' has no attribute 'convert_frame'"): where a collected test has a timeout
    of its own, import it now, before any timer runs (a run that trains imports it anyway)."""
    if any(item.get_closest_marker("timeout") is not None for item in session.items):
        import torch._dynamo  # noqa: F401


@pytest.fixture(autouse=True)
def signal_state_is_restored():
    """Every test leaves the process's signal handling as it found it.

    A run, a library or a test that installs a handler or blocks a signal in the main thread and
    keeps it makes later signal tests depend on the order the suite runs in: this
    fixture names the test that leaked instead.
    """
    before = _signal_state()
    yield
    after = _signal_state()
    assert after == before, f"this test left the signal state changed: {before} -> {after}"


def ppo_epochs(config: str, overrides: list[str], num_envs: int, epochs: int) -> tuple[list[dict], PPO]:
    """Same-seed PPO epochs of ``config`` on a CPU, driven by hand (collect, then update): each update's stats and
    the trainer (rlchain.algos.ppo.ppo.PPO), its env closed."""
    params = Runner().load(config, overrides).params
    torch.manual_seed(0)
    env = build_env(params, num_envs, 0)
    model = build_model(params, env, torch.device("cpu"))
    ppo = Loop(params, PPO, env, model, torch.device("cpu"), None, TrainLogger(None, False), 0,
               {}).algorithm
    ppo.collector.place(torch.as_tensor(env.reset(seed=0)))
    out = []
    for _ in range(epochs):
        ppo.collect()
        out.append(ppo.update())
    env.close()
    return out, ppo
