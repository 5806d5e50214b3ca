"""Ray env runners on a local Ray (2 workers): the VecEnv contract, killed and hung workers, PPO runs.

One Ray instance for the module (tests/smoke/ray_session.py; its start takes several seconds); every test has a
timeout and closes its envs, so no actor outlives its test. What a test costs is mostly its actors' starts (each
a process that imports ray, gymnasium and rlchain's env layer to build its envs: no torch for these numpy envs;
APPO's runners import torch), so each test starts as few as it needs: the runs are a few epochs of tiny envs and
the fault tests kill the fewest workers that show the behaviour.
"""

import glob
import os
import signal
import time

import gymnasium as gym
import numpy as np
import pytest

from rlchain import Runner, env_configurations
from rlchain.config.run import EnvRunnersConfig
from rlchain.envs.factory import make_vec_env
from rlchain.envs.ray.ray_env import WorkerLost
from rlchain.training.events import Callback
from tests.conftest import ROOT, installed
from tests.smoke import ray_session
from tests.smoke.ray_envs import SleepyCartPole

# a mark, not pytest.importorskip: that imports ray when the file is collected, in every pytest process
pytestmark = [pytest.mark.smoke, installed("ray")]
CPUS = 4  # logical CPUs of the test cluster: 2 workers x 1 CPU, plus room while a dead one is replaced
# A (re)started worker may take this long to build its envs: on 2 busy cores a worker process's imports alone
# can take over a minute. The product's default (120 s) is for a real cluster; a correct test run never waits it
# out, and a broken start still fails (the test's own timeout).
START_TIMEOUT_S = 300.0


@pytest.fixture(scope="module", autouse=True)
def ray_cluster():
    with ray_session.session(CPUS):
        yield


def wait_for_free_cpus(expected, seconds=20.0):
    import ray

    deadline = time.monotonic() + seconds
    while ray.available_resources().get("CPU", 0) < expected and time.monotonic() < deadline:
        time.sleep(0.2)
    return ray.available_resources().get("CPU", 0)


def runners(**kw):
    return EnvRunnersConfig(**{"num_workers": 2, "step_timeout_s": 20.0, "start_timeout_s": START_TIMEOUT_S, **kw})


@pytest.mark.timeout(600)
def test_contract_matches_local_backend_and_survives_killed_workers():
    import ray

    env = make_vec_env("CartPole-v1", {"max_episode_steps": 12}, 4, 3, "sync", env_runners=runners(max_restarts=1))
    local = make_vec_env("CartPole-v1", {"max_episode_steps": 12}, 4, 3, "sync")
    try:
        assert env.num_envs == 4 and env.observation_space == local.observation_space
        assert [(s.start, s.stop) for s in env.slices] == [(0, 2), (2, 4)]
        obs = env.reset()
        np.testing.assert_array_equal(obs, local.reset())  # env i seeded 3 + i on whichever worker
        rng = np.random.default_rng(0)
        ended = 0
        for _ in range(30):  # terminations and the time-out at 12 steps: same-step autoreset, final_obs
            actions = rng.integers(0, 2, 4)
            got, ref = env.step(actions), local.step(actions)
            for name in ("obs", "reward", "terminated", "truncated", "final_obs"):
                a, b = getattr(got, name), getattr(ref, name)
                assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b), name
            assert got.obs.shape == (4, 4) and got.reward.dtype == np.float32 and got.terminated.dtype == bool
            assert "dropped" not in got.infos
            ended += int((got.terminated | got.truncated).sum())
        assert ended >= 8

        before = got.obs
        ray.kill(env.workers[1])  # worker 1 holds envs 2 and 3
        _wait_dead(ray, env.workers[1])  # ray.kill is asynchronous: a loaded machine may run one more step
        cut = env.step(np.zeros(4, dtype=np.int64))
        assert cut.infos["dropped"].tolist() == [False, False, True, True]
        assert cut.truncated[2:].all() and not cut.terminated[2:].any() and (cut.reward[2:] == 0).all()
        np.testing.assert_array_equal(cut.final_obs[2:], before[2:])  # the obs the policy acted on
        assert (np.abs(cut.obs[2:]) <= 0.05).all()  # a fresh CartPole episode
        assert env.dropped_episodes == 2 and env.restarts == [0, 1]
        assert env.log_stats() == {"env/dropped_episodes": 2.0, "env/worker_restarts": 1.0}

        os.kill(env.worker_pids()[0], signal.SIGKILL)  # a crash, not a polite kill
        _wait_dead(ray, env.workers[0])
        cut = env.step(np.zeros(4, dtype=np.int64))
        assert cut.infos["dropped"].tolist() == [True, True, False, False] and env.dropped_episodes == 4
        assert "dropped" not in env.step(np.zeros(4, dtype=np.int64)).infos  # and it goes on normally

        # worker 0 dies again: each slot had its one restart (counted per slot: worker 1's does not use up
        # worker 0's), the second is one too many. The kill is waited for, so which step sees the death does
        # not depend on how loaded the machine is.
        ray.kill(env.workers[0])
        _wait_dead(ray, env.workers[0])
        with pytest.raises(WorkerLost) as lost:
            env.step(np.zeros(4, dtype=np.int64))
        message = str(lost.value)
        assert env.restarts == [2, 1] and "ray env worker 0 (envs 0-1) failed (ActorDiedError" in message
        assert "more than env_runners.max_restarts = 1 restarts" in message and "\n" not in message
    finally:
        env.close()
        local.close()
    assert env.workers == [] and wait_for_free_cpus(CPUS) == CPUS  # the actors are gone


@pytest.mark.timeout(600)
def test_hung_worker_is_replaced_after_the_step_timeout(tmp_path):
    """A user-registered env (shipped to the workers) that stops answering: no hang, the run goes on."""
    gym.register("SleepyCartPole-test", entry_point=SleepyCartPole)
    env_configurations.register("SleepyCartPole-ray", {"env_creator": lambda **kw: gym.make(
        "SleepyCartPole-test", **kw)}, overwrite=True)
    flag = str(tmp_path / "hang")
    env = make_vec_env("SleepyCartPole-ray", {"flag": flag}, 4, 0, "sync", env_runners=runners(step_timeout_s=3.0))
    try:
        env.reset()
        env.step(np.zeros(4, dtype=np.int64))
        open(flag, "w").close()
        start = time.monotonic()
        cut = env.step(np.zeros(4, dtype=np.int64))
        waited = time.monotonic() - start
        assert 3.0 <= waited < 40.0
        assert not os.path.exists(flag) and sum(env.restarts) == 1 and env.dropped_episodes == 2
        assert cut.infos["dropped"].sum() == 2 and cut.truncated[cut.infos["dropped"]].all()
        assert "dropped" not in env.step(np.zeros(4, dtype=np.int64)).infos
    finally:
        env.close()
        del gym.registry["SleepyCartPole-test"], gym.registry["SleepyCartPole-ray"]


@pytest.mark.timeout(600)
def test_bad_env_name_is_a_one_line_config_error_from_the_worker():
    with pytest.raises(ValueError) as err:
        make_vec_env("CartPol-v1", {}, 2, 0, "RAY", env_runners=runners(num_workers=1))
    assert str(err.value).startswith("params.config.env_name: unknown environment 'CartPol-v1'; did you mean "
                                     "'CartPole-v1'")
    assert "\n" not in str(err.value)
    assert wait_for_free_cpus(CPUS) == CPUS  # the workers of the failed start were stopped


def ray_ppo_config(tmp_path, epochs, **runner_keys):
    return {"params": {
        "seed": 3,
        "algo": {"name": "a2c_discrete"},
        "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [32, 32]}},
        "config": {"name": "ray_cartpole", "env_name": "CartPole-v1", "device": "cpu", "vecenv_type": "RAY",
                   "env_runners": {"num_workers": 2, "step_timeout_s": 20, "start_timeout_s": START_TIMEOUT_S,
                                   **runner_keys},
                   "num_actors": 8, "horizon_length": 32, "minibatch_size": 128, "mini_epochs": 2,
                   "learning_rate": 1e-3, "max_epochs": epochs, "save_best_after": 0, "print_stats": False,
                   "train_dir": str(tmp_path / "runs")},
    }}


class KillWorker(Callback):
    """Kills a worker's process (``worker``: its index) at the end of the given epochs; remembers the env."""

    def __init__(self, epochs, worker=1):
        self.epochs, self.worker, self.env, self.killed = epochs, worker, None, 0

    def on_epoch_end(self, ctx, stats, episodes):
        self.env = ctx.training_env
        if ctx.state.epoch in self.epochs:
            os.kill(ctx.training_env.worker_pids()[self.worker], signal.SIGKILL)
            self.killed += 1


@pytest.mark.timeout(600)
def test_ppo_run_on_ray_workers_goes_on_after_a_killed_worker_and_ends_in_one_line_when_it_keeps_dying(tmp_path):
    """One PPO run on 2 Ray workers of 8 envs each (TestGoalReach-v0), env_runners.max_restarts 1: worker 1's
    process is SIGKILLed after epoch 2 and the run goes on (epoch 3 trains on its replacement), worker 1's 8
    episodes in flight dropped and counted (TensorBoard env/dropped_episodes); killed again after epoch 3, its
    second restart is one too many and the run ends at epoch 4 with one line naming the worker, its actors
    stopped. The info['success'] the workers report (gymnasium same-step resets, so in final_info too) reaches
    the learner: episodes/success_rate and env_info/success are logged every epoch. 3 actor starts in all."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    killer = KillWorker(epochs={2, 3})
    runner = Runner().load(os.path.join(ROOT, "rlchain", "configs", "ppo_test_goal_reach.yaml"), [
        "params.config.vecenv_type=RAY", "params.config.env_runners.num_workers=2",
        "params.config.env_runners.max_restarts=1", f"params.config.env_runners.start_timeout_s={START_TIMEOUT_S}",
        "params.config.max_epochs=6", "params.config.success_to_win=1.0", "params.config.log_info_keys=[success]",
        "params.config.print_stats=false", f"params.config.train_dir={tmp_path}"])
    with pytest.raises(Exception) as err:
        runner.train(callbacks=[killer])
    message = str(err.value)
    assert "env step failed at epoch 4" in message and "WorkerLost: ray env worker 1 (envs 8-15)" in message
    assert "more than env_runners.max_restarts = 1 restarts" in message and "\n" not in message
    assert killer.killed == 2 and wait_for_free_cpus(CPUS) == CPUS
    assert type(killer.env).__name__ == "RayVecEnv" and killer.env.dropped_episodes == 8  # worker 1's 8 envs
    assert killer.env.restarts == [0, 2]
    [summaries] = glob.glob(os.path.join(str(tmp_path), "*", "summaries"))
    events = EventAccumulator(summaries)
    events.Reload()
    dropped = [e.value for e in events.Scalars("env/dropped_episodes")]
    assert dropped == [0, 0, 8]  # epochs 1-3: the restarted worker's envs stepped through epoch 3
    rates = [e.value for e in events.Scalars("episodes/success_rate")]
    step_success = [e.value for e in events.Scalars("env_info/success")]
    assert len(rates) == 3 and all(0.0 <= r <= 1.0 for r in rates) and max(rates) > 0  # episodes end on success
    assert len(step_success) == 3 and 0.0 <= min(step_success) <= max(step_success) <= 1.0


def _wait_dead(ray, worker, seconds=30.0):
    """Block until ``worker`` no longer answers (ray.kill only requests the kill)."""
    deadline = time.time() + seconds
    while time.time() < deadline:
        try:
            ray.get(worker.pid.remote(), timeout=2)
        except Exception:
            return
        time.sleep(0.05)
    raise AssertionError("the killed Ray worker still answers")


class KillAppoRunner(Callback):
    """SIGKILLs appo Ray runner 1's process at the end of epoch ``kill_at``; once the pool has replaced it and trained
    an epoch more, asks the run to stop. How soon Ray reports a dead actor depends on the machine's load, so the run
    waits for it (up to its max_epochs) instead of racing it to a fixed epoch."""

    def __init__(self, kill_at):
        self.kill_at, self.restarts, self.lost, self.seen_at = kill_at, None, None, None

    def on_epoch_end(self, ctx, stats, episodes):
        pool, epoch = ctx.algorithm.pool, ctx.state.epoch
        if epoch == self.kill_at:
            os.kill(pool.worker_pids()[1], signal.SIGKILL)
        elif epoch > self.kill_at and pool.restarts[1] and self.seen_at is None:
            self.seen_at = epoch
        elif self.seen_at is not None and epoch > self.seen_at:
            ctx.request_stop("the killed runner was replaced")

    def on_train_end(self, ctx, result):
        self.restarts, self.lost = list(ctx.algorithm.pool.restarts), ctx.algorithm.pool.lost_fragments


@pytest.mark.timeout(600)
def test_appo_on_ray_actors_finishes_despite_a_killed_runner(tmp_path):
    """APPO's 2 Ray runner actors: runner 1's process is SIGKILLed after epoch 2, its fragment in progress is lost,
    the runner is restarted and the run trains on, then stops cleanly with a checkpoint."""
    raw = ray_ppo_config(tmp_path, epochs=400)
    raw["params"]["algo"]["name"] = "appo"
    config = raw["params"]["config"]
    del config["vecenv_type"]
    config.update(horizon_length=8, minibatch_size=32, appo={"runners": "ray", "learner_queue_size": 4})
    killer = KillAppoRunner(kill_at=2)
    result = Runner().load(raw).train(callbacks=[killer])
    assert killer.seen_at is not None, "the killed runner was never replaced"
    assert result.epoch == killer.seen_at + 1 and "the killed runner was replaced" in result.stop_reason
    assert killer.restarts == [0, 1] and killer.lost == 1
    assert wait_for_free_cpus(CPUS) == CPUS  # the pool's actors were stopped
