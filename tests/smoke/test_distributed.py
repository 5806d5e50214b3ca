"""torchrun with 2 CPU processes (gloo): training, identical ranks, one run folder, resume, bad launches.

Every test runs torchrun (``python -m torch.distributed.run``) as a subprocess with a timeout, so a
hang fails the test instead of the CI job. The runs that check one property each of a short training share
one launch (tests/smoke/dist_scenarios.py), the bad launches and a dying rank too: a launch costs about 15 s of CPU
before it trains.
``DumpState`` (named in the config's ``callbacks``) has
each rank save its final parameters, buffers and optimizer state for the comparisons.
"""

import contextlib
import glob
import json
import os
import re
import signal
import sys
import threading
import time

import pytest
import torch

from rlchain.training.events import Callback
from tests.conftest import CONFIGS, ROOT
from tests.smoke.cli_server import run_python
from tests.smoke.docs_background import running  # a zombie (ended, not yet reaped by torchrun) does not run

pytestmark = pytest.mark.smoke

DUMP_ENV = "RLCHAIN_TEST_DIST_DUMP"
SCORE = 60  # the two-rank run's score_to_win
CALLBACK = 'params.config.callbacks=["tests.smoke.test_distributed:DumpState"]'


class DumpState(Callback):
    """Test-only: each rank writes its final model, optimizer and counters to $RLCHAIN_TEST_DIST_DUMP."""

    def on_train_end(self, ctx, result):
        folder = os.environ.get(DUMP_ENV)
        if not folder:
            return
        rank = ctx.state.rank
        state = {"model": ctx.model.state_dict(), "optimizer": ctx.algorithm.agent.optimizer.state_dict(),
                 "lr": ctx.algorithm.agent.lr, "epoch": ctx.state.epoch, "frames": ctx.state.frames,
                 "best_reward": ctx.state.best_reward, "seed": ctx.state.seed, "run_dir": result.run_dir}
        if getattr(ctx.algorithm, "reference", None) is not None:  # GRPO's frozen initial policy
            state["reference"] = ctx.algorithm.reference.state_dict()
        if getattr(ctx.algorithm, "central_value", None) is not None:
            state["central_value"] = ctx.algorithm.central_value.state_dict()
            state["cv_optimizer"] = ctx.algorithm.cv_agent.optimizer.state_dict()
        torch.save(state, os.path.join(folder, f"rank{rank}.pt"))


class KillRank1(Callback):
    """Test-only: rank 1 dies (SIGKILL) at the end of epoch 3, as a crashed or OOM-killed worker would."""

    def on_epoch_end(self, ctx, stats, episodes):
        if ctx.state.rank == 1 and ctx.state.epoch == 3:
            os.kill(os.getpid(), signal.SIGKILL)


class StopRank1(Callback):
    """Test-only: rank 1 stops (SIGSTOP) at the end of epoch 2, as a wedged GPU or file system would. Each rank
    writes its pid there first (rank{N}.pid), so the test sees rank 0 end and can kill the stopped rank: torchrun
    runs each rank in a session of its own."""

    def on_epoch_end(self, ctx, stats, episodes):
        if ctx.state.epoch == 2:
            with open(f"rank{ctx.state.rank}.pid", "w", encoding="utf-8") as fh:
                fh.write(str(os.getpid()))
            if ctx.state.rank == 1:
                os.kill(os.getpid(), signal.SIGSTOP)


def torchrun(args, tmp_path, nproc=2, timeout=180, script=None, module=None, launcher=()):
    """Run ``torchrun --standalone --nproc_per_node=nproc`` on runner.py (or a script / -m module), in a child of
    the smoke tests' fork server (tests/smoke/cli_server.py): torchrun's launcher, rendezvous and monitoring as
    they are, its workers forks of the launcher instead of new interpreters (tests/smoke/forkserver.py,
    fork_torchrun_workers), each about 4 s of CPU less to start. RLCHAIN_TESTS_FRESH=1: fresh processes.
    ``launcher``: more of torchrun's own flags."""
    dumps = tmp_path / "dumps"
    dumps.mkdir(exist_ok=True)
    for old in dumps.glob("rank*.pt"):
        old.unlink()
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""),
               OMP_NUM_THREADS="1", **{DUMP_ENV: str(dumps)})
    target = ["-m", module] if module else [script or os.path.join(ROOT, "runner.py")]
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nnodes=1",
           f"--nproc_per_node={nproc}", *launcher, *target, *args]
    out = run_python(cmd, tmp_path, env, timeout)  # the launcher and its workers: forks of the preloaded server
    return out, dumps


def overrides(tmp_path, *extra):
    return ["params.config.multi_gpu=True", f"params.config.train_dir={tmp_path}/runs", CALLBACK, *extra]


def load_dumps(dumps, nproc=2):
    files = sorted(glob.glob(str(dumps / "rank*.pt")))
    assert len(files) == nproc, files
    return [torch.load(f, weights_only=False) for f in files]


def assert_ranks_identical(states):
    """Bit-identical parameters, buffers (normalizers), optimizer state, lr and counters on every rank."""
    first = states[0]
    for other in states[1:]:
        for model, optimizer in (("model", "optimizer"), ("central_value", "cv_optimizer")):
            assert (model in first) == (model in other)
            if model not in first:
                continue
            assert first[model].keys() == other[model].keys()
            for key, tensor in first[model].items():
                assert torch.equal(tensor, other[model][key]), f"{model} {key} differs between ranks"
            assert first[optimizer]["state"], "the optimizer never stepped"
            for pid, slots in first[optimizer]["state"].items():
                for name, value in slots.items():
                    assert torch.equal(value, other[optimizer]["state"][pid][name]), f"{optimizer} {pid}.{name}"
        for key in ("lr", "epoch", "frames", "best_reward"):
            assert first[key] == other[key], key
    assert len({s["seed"] for s in states}) == len(states), "ranks must step differently seeded envs"


# ----- one launch, several runs: each rank runs them one after the other (tests/smoke/dist_scenarios.py) -----
# the runs that must work, then the bad launches (each must fail before a run folder), then a rank that dies, which
# ends the launch
SCENARIOS = ("score", "score_resume", "straight", "resumed", "normalizers", "appo", "rnn", "central_value", "grpo",
             "aux_loss", "distill", "collectives", "without_multi_gpu", "different_configs", "different_checkpoints",
             "dead_rank")


@pytest.fixture(scope="module")
def scenarios(tmp_path_factory):
    """One torchrun launch running every scenario: (the launch's output, its folder, when it ended: time.time())."""
    folder = tmp_path_factory.mktemp("dist_scenarios")
    out, _ = torchrun([str(folder), *SCENARIOS], folder, timeout=840, module="tests.smoke.dist_scenarios")
    return out, folder, time.time()


def scenario_status(scenarios, name) -> list[str]:
    """Each rank's exit status of scenario ``name`` ('missing' where that rank never got to write it)."""
    where = scenarios[1] / name
    return [(where / f"status{rank}.txt").read_text() if (where / f"status{rank}.txt").exists() else "missing"
            for rank in range(2)]


def scenario_states(scenarios, name):
    out = scenarios[0]
    assert scenario_status(scenarios, name) == ["0", "0"], out.stdout[-3000:] + out.stderr[-3000:]
    return load_dumps(scenarios[1] / name / "dumps")


def scenario_output(scenarios, name, rank=0):
    """What rank ``rank`` printed on stdout during scenario ``name``."""
    return (scenarios[1] / name / f"stdout{rank}.txt").read_text()


@pytest.mark.timeout(900)
def test_two_ranks_reach_cartpole_score_identically_then_resume(scenarios):
    # a score of 60 (a random policy scores about 22) is a few epochs: what is tested is that every rank stops at
    # the same epoch on the reduced score, not how far PPO learns (tests/learning/test_learning.py)
    states = scenario_states(scenarios, "score")
    stdout = scenario_output(scenarios, "score")
    assert f"score_to_win {SCORE:.1f} reached" in stdout
    # rank 0 alone prints progress
    assert stdout.count("rlchain: training") == 1 and "rlchain: training" not in scenario_output(scenarios, "score", 1)
    last = re.findall(r"reward ([\d.]+) \| best ([\d.]+)", stdout)[-1]
    stop = re.search(r"mean reward ([\d.]+), best ([\d.]+)", stdout).groups()
    assert stop == last, (stop, last)  # the stop line's mean and best are every rank's, as the epoch line's
    assert_ranks_identical(states)
    epoch = states[0]["epoch"]
    assert states[0]["frames"] == epoch * 32 * 16 * 2  # frames count both ranks
    assert states[0]["best_reward"] >= SCORE

    runs = [os.path.realpath(run) for run in glob.glob(str(scenarios[1] / "score" / "runs" / "*"))]
    first = os.path.realpath(states[0]["run_dir"])
    assert first in runs
    # one run folder, one set of checkpoints, one TensorBoard log
    assert sorted(os.listdir(os.path.join(first, "nn"))) == ["cartpole.pth", "last_cartpole.pth"]
    assert len(glob.glob(os.path.join(first, "summaries", "events.out.tfevents.*"))) == 1
    last = os.path.join(first, "nn", "last_cartpole.pth")
    saved = torch.load(last, weights_only=False)
    assert saved["epoch"] == epoch
    assert all(torch.equal(value, states[0]["model"][key]) for key, value in saved["model"].items())

    resumed = scenario_output(scenarios, "score_resume")  # score's last checkpoint, to epoch + 2
    assert f"from {last} at epoch {epoch}" in resumed
    assert f"epoch {epoch + 2}/{epoch + 2}" in resumed and f"epoch {epoch}/" not in resumed
    states = scenario_states(scenarios, "score_resume")
    assert_ranks_identical(states)
    assert states[0]["epoch"] == epoch + 2 and states[0]["frames"] == (epoch + 2) * 1024
    assert len(runs) == 2  # the resume's folder, written by rank 0 only


@pytest.mark.timeout(900)
def test_two_rank_resume_is_bit_identical(scenarios):
    """Exact resume across ranks: each rank's envs, episodes and random streams are in rank 0's checkpoint;
    resuming the epoch-3 checkpoint to 6 equals 6 straight on both ranks (parameters, optimizer, lr, counters,
    episode statistics)."""
    straight, resumed = scenario_states(scenarios, "straight"), scenario_states(scenarios, "resumed")
    nn, resumed_nn = (glob.glob(str(scenarios[1] / name / "runs" / "*" / "nn"))[0] for name in ("straight", "resumed"))
    at_3 = torch.load(os.path.join(nn, "cartpole_ep_3.pth"), weights_only=False)
    assert at_3["epoch"] == 3 and len(at_3["ranks"]) == 2
    assert all(part["run_state"]["env"] is not None for part in at_3["ranks"])
    out = "".join((scenarios[1] / "resumed" / f"{stream}{rank}.txt").read_text()
                  for stream in ("stdout", "stderr") for rank in range(2))
    assert "starts new episodes" not in out
    for rank in range(2):
        a, b = straight[rank], resumed[rank]
        for key, tensor in a["model"].items():
            assert torch.equal(tensor, b["model"][key]), f"rank {rank} {key}"
        for pid, slots in a["optimizer"]["state"].items():
            for name, value in slots.items():
                assert torch.equal(value, b["optimizer"]["state"][pid][name]), f"rank {rank} optimizer {pid}.{name}"
        for key in ("lr", "epoch", "frames", "best_reward"):
            assert a[key] == b[key], (rank, key)
    ends = [torch.load(os.path.join(folder, "last_cartpole.pth"), weights_only=False)["ranks"]
            for folder in (nn, resumed_nn)]
    assert [part["episodes"] for part in ends[0]] == [part["episodes"] for part in ends[1]]
    assert ends[0][0]["episodes"] != ends[0][1]["episodes"]  # each rank played its own games


@pytest.mark.timeout(900)
def test_normalizers_and_adaptive_lr_stay_identical(scenarios):
    """Pendulum: normalize_input, normalize_value and the adaptive-KL schedule, 3 epochs on 2 ranks."""
    states = scenario_states(scenarios, "normalizers")
    assert_ranks_identical(states)
    model = states[0]["model"]
    # each normalizer folded both ranks' batches (16 envs x 64 steps per rank and epoch)
    assert model["running_mean_std.count"].item() == pytest.approx(3 * 2 * 16 * 64, abs=1e-3)
    # value_normalizer: rl_games folds each sample's value prediction and its return: twice the count
    assert model["value_mean_std.count"].item() == pytest.approx(2 * 3 * 2 * 16 * 64, abs=1e-3)


@pytest.mark.timeout(900)
def test_appo_learner_is_data_parallel(scenarios):
    """appo under torchrun: each rank has its runners and learner; gradients, normalizers (each folds both
    ranks' batches), the adaptive lr and the frame counter stay identical."""
    states = scenario_states(scenarios, "appo")
    assert_ranks_identical(states)
    assert states[0]["model"]["running_mean_std.count"].item() == pytest.approx(3 * 2 * 16 * 64, abs=1e-3)
    assert states[0]["frames"] >= 3 * 2 * 16 * 64


@pytest.mark.timeout(900)
def test_rnn_policy_stays_identical(scenarios):
    """LSTM policy trained on sequence minibatches: the same gradient sync keeps the ranks equal."""
    states = scenario_states(scenarios, "rnn")
    assert any(".rnn." in key for key in states[0]["model"])
    assert_ranks_identical(states)


@pytest.mark.timeout(900)
def test_central_value_critic_stays_identical(scenarios):
    """The asymmetric critic (own optimizer, minibatches, value normalizer) is synced like the actor."""
    states = scenario_states(scenarios, "central_value")
    assert "central_value" in states[0]
    assert_ranks_identical(states)


@pytest.mark.timeout(900)
def test_grpo_from_an_embodichain_config_with_distributed(scenarios):
    """GRPO through train.py --distributed with an EmbodiChain-layout config: each rank normalises its own
    groups (8 envs per rank, groups of 4, so none straddles two ranks); gradients averaged, the frozen
    reference policy is rank 0's on both ranks."""
    states = scenario_states(scenarios, "grpo")
    assert_ranks_identical(states)
    assert states[0]["frames"] == 2 * 16 * 8 * 2  # iterations x buffer_size x num_envs x ranks
    for key, tensor in states[0]["reference"].items():
        assert torch.equal(tensor, states[1]["reference"][key]), key


@pytest.mark.timeout(900)
def test_aux_loss_network_stays_identical(scenarios):
    """testnet_aux_loss: its auxiliary loss is part of the loss whose gradients the ranks average."""
    states = scenario_states(scenarios, "aux_loss")
    assert "a2c_network.aux_loss_linear.weight" in states[0]["model"]
    assert_ranks_identical(states)


# ----- bad launches fail at once, with one line -------------------------------------------------
@pytest.mark.timeout(60)
def test_two_ranks_distill_cartpole_identically(scenarios):
    """algo distill with multi_gpu: the ranks' students stay identical (its own launch before, in
    test_distill_sac_multigpu.py)."""
    states = scenario_states(scenarios, "distill")
    stdout = scenario_output(scenarios, "distill")
    assert stdout.count("rlchain: training") == 1  # rank 0 alone prints progress
    assert "rlchain: training" not in scenario_output(scenarios, "distill", 1)
    assert_ranks_identical(states)  # parameters, the normalizer's running stats, Adam's state
    assert states[0]["epoch"] == 3 and states[0]["frames"] == 3 * 4 * 16 * 2  # frames count both ranks
    runs = glob.glob(str(scenarios[1] / "distill" / "runs" / "*"))
    assert len(runs) == 1 and os.listdir(os.path.join(runs[0], "nn"))  # rank 0 alone writes the run folder


def test_multi_gpu_without_torchrun_fails_fast(tmp_path):
    env = dict(os.environ, PYTHONPATH=ROOT)
    for name in ("RANK", "WORLD_SIZE", "LOCAL_RANK", "MASTER_ADDR", "MASTER_PORT"):
        env.pop(name, None)
    out = run_python([sys.executable, os.path.join(ROOT, "runner.py"), "--train", "--file",
                      os.path.join(CONFIGS, "ppo_cartpole.yaml"), *overrides(tmp_path)], tmp_path, env, 50)
    assert out.returncode == 2
    assert "config error:" in out.stderr and "params.config.multi_gpu: True needs the torchrun launcher" in out.stderr
    assert "torchrun --standalone --nproc_per_node=N runner.py" in out.stderr
    assert not (tmp_path / "runs").exists()


def failed_launch(scenarios, name):
    """Both ranks' stderr during scenario ``name`` (a bad launch of the scenarios' launch); asserts that both
    failed and wrote no run folder."""
    folder = scenarios[1]
    assert not (folder / name / "runs").exists()
    assert "0" not in scenario_status(scenarios, name) and "missing" not in scenario_status(scenarios, name)
    return "".join((folder / name / f"stderr{rank}.txt").read_text() for rank in range(2))


@pytest.mark.timeout(900)
def test_torchrun_without_multi_gpu_fails_fast(scenarios):
    stderr = failed_launch(scenarios, "without_multi_gpu")
    assert "launched by torchrun with WORLD_SIZE=2 but multi_gpu is False" in stderr, stderr


@pytest.mark.timeout(900)
def test_ranks_with_different_configs_fail_fast(scenarios):
    stderr = failed_launch(scenarios, "different_configs")
    assert "params.config.multi_gpu: rank 1 parsed a different config or seed than rank 0" in stderr, stderr


@pytest.mark.timeout(900)
def test_ranks_resuming_different_checkpoints_fail_before_a_run_folder(scenarios):
    from tests.smoke.dist_scenarios import last_checkpoint

    stderr = failed_launch(scenarios, "different_checkpoints")
    assert "params.config.multi_gpu: rank 1 differs from rank 0" in stderr, stderr
    _, epoch = last_checkpoint(str(scenarios[1] / "score"), "last_cartpole.pth")  # what rank 0 resumed
    assert "'resume_epoch': None" in stderr and f"'resume_epoch': {epoch}" in stderr, stderr


@pytest.mark.timeout(900)
def test_a_dead_rank_ends_the_run_with_a_clear_message(scenarios):
    """Rank 1 dies (SIGKILL) at epoch 3 of the launch's last scenario: torchrun ends rank 0 and the launch."""
    out, folder, ended = scenarios
    where = folder / "dead_rank"
    assert out.returncode != 0
    assert scenario_status(scenarios, "dead_rank")[1] == "missing"  # rank 1 never returned from the run
    start = float((where / "started0.txt").read_text())
    assert ended - start < 60  # torchrun and gloo end rank 0 at once, no collective timeout
    assert "rank      : 1 (local_rank: 1)\n  exitcode  : -9" in out.stderr  # torchrun names the dead rank
    # rank 0 either lost its peer inside a collective or got torchrun's SIGTERM between collectives
    stdout, stderr = ((where / f"{stream}0.txt").read_text() for stream in ("stdout", "stderr"))
    lost = "distributed error: rank 0: a collective with the other ranks failed" in stderr
    stopped = "SIGTERM received" in stdout or "interrupted" in stderr
    assert lost or stopped, stdout[-2000:] + stderr[-3000:]


def _kill_stopped_rank_after_rank0(folder, done: threading.Event) -> None:
    """Once rank 0 has ended by itself, SIGKILL the stopped rank 1, as torchrun does after its wait."""
    pids = [folder / "rank0.pid", folder / "rank1.pid"]
    while not done.wait(0.1):
        if all(path.exists() and path.read_text() for path in pids) and not running(int(pids[0].read_text())):
            with contextlib.suppress(ProcessLookupError):
                os.kill(int(pids[1].read_text()), signal.SIGKILL)
            return


def test_a_stalled_rank_ends_the_run_within_the_collective_timeout(tmp_path):
    """Rank 1 stops (SIGSTOP) and never answers: rank 0 gives up after multi_gpu_timeout_s (2 s here) and a roll
    call, with one line naming rank 1, and ends. torchrun then sends the stopped rank SIGTERM, which waits for a
    SIGCONT, and SIGKILLs it after 30 s (torch 2.13's agent stops a failed worker group with a fixed 30 s, not its
    --shutdown-timeout): the test sends that SIGKILL itself once rank 0 has ended, so it waits on rank 0's
    timeout, not on torchrun's. A rank 0 that never ends still hangs the launch until the test's own bound."""
    args = ["--train", "--file", os.path.join(CONFIGS, "ppo_cartpole.yaml"),
            *overrides(tmp_path, "params.config.score_to_win=100000", "params.config.max_epochs=200",
                       "params.config.multi_gpu_timeout_s=2"),
            'params.config.callbacks=["tests.smoke.test_distributed:StopRank1"]']
    done = threading.Event()
    killer = threading.Thread(target=_kill_stopped_rank_after_rank0, args=(tmp_path, done), daemon=True)
    killer.start()
    try:
        out, _ = torchrun(args, tmp_path, timeout=120)  # the test's own bound; the run's is 2 s + the roll call
    finally:
        done.set()
        killer.join()
        stopped = tmp_path / "rank1.pid"
        if stopped.exists():  # rank 1, stopped in a session of its own, would outlive a launch that timed out
            with contextlib.suppress(ProcessLookupError, ValueError):
                os.kill(int(stopped.read_text()), signal.SIGKILL)
    assert out.returncode != 0
    found = [line for line in out.stderr.splitlines() if "distributed error: rank 0" in line]
    assert found, out.stderr[-4000:]
    assert "rank 1 did not answer within 2 s (params.config.multi_gpu_timeout_s)" in found[0]


# ----- the collectives with two real processes ---------------------------------------------------
@pytest.mark.timeout(900)
def test_collectives_with_two_processes(scenarios):
    out, folder, _ = scenarios
    assert scenario_status(scenarios, "collectives") == ["0", "0"], out.stderr[-3000:]
    results = [json.loads((folder / "collectives" / f"collectives{r}.json").read_text()) for r in range(2)]
    for r in results:
        assert r["all_reduce_calls"] == 1
        assert r["grad_a"] == [1.5 * i for i in range(6)]  # (1 + 2) / 2 * arange
        assert r["grad_b"] == [0.5] * 4  # rank 0 had no gradient: it counts as zeros
        assert r["moment_error"] < 1e-12 and r["count"] == 5 + 15
        assert r["kl_mean"] == 0.05 and r["lr"] == pytest.approx(1e-3 / 1.5)
        assert r["episodes"] == {"reward": 2.0, "length": 20.0, "success": pytest.approx(2 / 3)}
        assert r["no_episodes"] is None
    assert results[0]["mean"] == results[1]["mean"] and results[0]["var"] == results[1]["var"]


def _collectives_worker(folder: str) -> None:
    """Run under torchrun (tests/smoke/dist_scenarios.py's ``collectives``): each rank computes the syncs for the
    test above to check against hand-computed values."""
    import collections

    import torch.distributed as dist

    from rlchain.algos.core.schedules import AdaptiveKLSchedule
    from rlchain.parallel import distributed as D

    dist.init_process_group("gloo")
    rank = dist.get_rank()
    pg = D.Distributed(rank, 2, rank, "gloo", seed=0)  # the Communicator the agents and normalizers use
    a, b = torch.nn.Parameter(torch.zeros(2, 3)), torch.nn.Parameter(torch.zeros(4))
    a.grad = (rank + 1.0) * torch.arange(6.0).reshape(2, 3)
    b.grad = torch.ones(4) if rank == 1 else None
    calls = []
    real = dist.all_reduce
    dist.all_reduce = lambda t, **kw: calls.append(1) or real(t, **kw)
    pg.average_gradients([a, b])
    dist.all_reduce = real

    batches = [torch.randn(5 + 10 * r, 3, generator=torch.Generator().manual_seed(r), dtype=torch.float64) * (r + 1)
               for r in range(2)]
    mine = batches[rank]
    mean, var, count = pg.combine_moments(mine.mean(0), mine.var(0, unbiased=False), mine.shape[0])
    union = torch.cat(batches)
    error = max(float((mean - union.mean(0)).abs().max()), float((var - union.var(0, unbiased=False)).abs().max()))

    schedule = AdaptiveKLSchedule(0.01)
    tracker = collections.namedtuple("T", "finished_returns finished_lengths finished_successes")
    episodes = pg.episode_stats(tracker([1.0, 3.0], [10, 30], [1.0, 0.0]) if rank == 0 else tracker([2.0], [20], [1.0]))
    result = {"all_reduce_calls": len(calls), "grad_a": a.grad.flatten().tolist(), "grad_b": b.grad.tolist(),
              "moment_error": error, "count": count, "mean": mean.tolist(), "var": var.tolist(),
              "kl_mean": pg.mean(0.1 if rank == 0 else 0.0),
              "lr": schedule.update(1e-3, kl=pg.mean(0.1 if rank == 0 else 0.0)),
              "episodes": episodes, "no_episodes": pg.episode_stats(tracker([], [], []))}
    with open(os.path.join(folder, f"collectives{rank}.json"), "w") as fh:
        json.dump(result, fh)
    dist.destroy_process_group()
