"""appo / impala with local runner threads: train -> play -> resume, TensorBoard tags, stale fragments,
backpressure, a killed runner, a runner that keeps dying, a straggler."""

import copy
import glob
import time

import pytest
import torch

from rlchain import Runner
from rlchain.algos.appo.appo import APPO
from rlchain.algos.appo.local_runners import LocalRunners
from rlchain.config.load import parse_params
from rlchain.config.run import EnvRunnersConfig
from rlchain.envs.ray.ray_env import worker_slices
from rlchain.envs.ray.ray_worker import EnvRecipe
from rlchain.errors import EnvError
from rlchain.models.build import build_model
from rlchain.runs import checkpoint
from rlchain.training.events import Callback

pytestmark = pytest.mark.smoke

APPO_CONFIG = {
    "params": {
        "seed": 3,
        "algo": {"name": "appo"},
        "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [16]}},
        "config": {"name": "a", "env_name": "CartPole-v1", "device": "cpu", "num_actors": 8, "horizon_length": 8,
                   "minibatch_size": 32, "mini_epochs": 1, "max_epochs": 6, "save_best_after": 0,
                   "env_runners": {"num_workers": 4, "max_restarts": 1},
                   "appo": {"learner_queue_size": 4}, "player": {"games_num": 2}},
    }
}


def config(tmp_path, algo="appo", **changes):
    raw = copy.deepcopy(APPO_CONFIG)
    raw["params"]["algo"]["name"] = algo
    raw["params"]["config"]["train_dir"] = str(tmp_path)
    for key, value in changes.items():
        node = raw["params"]["config"]
        *path, last = key.split(".")
        for part in path:
            node = node.setdefault(part, {})
        node[last] = value
    return raw


class Grab(Callback):
    """Each epoch's stats, and an action at a given epoch."""

    def __init__(self, at=None, action=None):
        self.stats, self.at, self.action = [], at, action

    def on_epoch_end(self, ctx, stats, episodes):
        self.stats.append(dict(stats))
        if self.at is not None and ctx.state.epoch == self.at:
            self.action(ctx)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("algo", ["appo", "impala"])
def test_train_play_resume_and_tags(tmp_path, algo):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    raw = config(tmp_path, algo)
    if algo == "impala":
        del raw["params"]["config"]["mini_epochs"]
    grab = Grab()
    result = Runner().load(raw).train(callbacks=[grab])
    assert result.epoch == 6 and result.frames >= 6 * 64
    assert all(s["policy_lag"] <= 4 for s in grab.stats) and grab.stats[-1]["queue_size"] <= 4
    events = EventAccumulator(glob.glob(f"{result.run_dir}/summaries")[0])
    events.Reload()
    tags = set(events.Tags()["scalars"])
    assert {"appo/policy_lag", "appo/queue_size", "appo/sample_throughput", "losses/a_loss", "losses/c_loss",
            "info/last_lr", "rewards/step", "performance/step_fps"} <= tags
    last = f"{result.run_dir}/nn/last_a.pth"
    played = Runner().load(raw).play(checkpoint=last, games=2, quiet=True)
    assert played.games == 2 and played.mean_reward > 0
    raw["params"]["config"]["max_epochs"] = 8
    resumed = Runner().load(raw).train(checkpoint=last)
    assert resumed.epoch == 8 and resumed.frames > result.frames


@pytest.mark.timeout(120)
def test_stale_fragments_are_dropped_and_counted(tmp_path):
    grab = Grab()
    Runner().load(config(tmp_path, **{"appo.max_policy_lag": 0, "max_epochs": 5})).train(callbacks=[grab])
    assert all(s["policy_lag"] == 0 for s in grab.stats)  # nothing older than the learner is trained on
    assert grab.stats[-1]["dropped_fragments"] > 0  # 4 runners, 1 fragment each per batch: some are behind


@pytest.mark.timeout(60)
def test_full_queue_stops_the_runners(tmp_path):
    runners = EnvRunnersConfig(num_workers=2)
    recipe = EnvRecipe.capture("CartPole-v1", {}, "auto")
    pool = LocalRunners(recipe, worker_slices(4, runners), 0, 8, 2, 1, 60.0)
    try:
        model = build_model(parse_params(config(tmp_path)), pool, torch.device("cpu"))
        pool.start(model, {k: v.clone() for k, v in model.state_dict().items()}, 0)
        time.sleep(1.5)  # nobody takes fragments
        assert pool.queue_size() == 2
        assert sum(r.fragments_sampled for r in pool.runners) <= 2 + 2  # the queue + one waiting per runner
        assert pool.get(1.0) is not None
    finally:
        pool.close()


class KillRunner(Callback):
    """Kill runner ``index`` at the given epochs (its thread dies mid-fragment); remember the restarts."""

    def __init__(self, index, epochs):
        self.index, self.epochs, self.restarts = index, epochs, None

    def on_epoch_end(self, ctx, stats, episodes):
        if ctx.state.epoch in self.epochs:
            pool = ctx.algorithm.pool
            pool.kill(self.index)
            pool.threads[self.index].join(timeout=10)
            assert not pool.threads[self.index].is_alive()

    def on_train_end(self, ctx, result):
        self.restarts = list(ctx.algorithm.pool.restarts)


@pytest.mark.timeout(120)
def test_killed_runner_is_replaced_and_the_run_goes_on(tmp_path):
    kill = KillRunner(1, {2})
    result = Runner().load(config(tmp_path, max_epochs=8)).train(callbacks=[kill])
    assert result.epoch == 8 and result.stop_reason.startswith("max_epochs")
    assert kill.restarts == [0, 1, 0, 0]


@pytest.mark.timeout(120)
def test_runner_that_keeps_dying_ends_the_run_with_one_line_and_a_checkpoint(tmp_path):
    with pytest.raises(EnvError) as err:  # max_restarts 1: the second death ends the run
        Runner().load(config(tmp_path, max_epochs=50)).train(callbacks=[KillRunner(0, {2, 4})])
    text = str(err.value)
    assert "appo runner 0" in text and "max_restarts = 1" in text and "saved to" in text
    assert "\n" not in text
    assert glob.glob(f"{tmp_path}/*/nn/last_a.pth")


@pytest.mark.timeout(120)
def test_a_straggler_does_not_set_the_pace(tmp_path, monkeypatch):
    # runner 0 sleeps 10x longer per env step: 8 steps = 0.4 s a fragment against 0.04 s for the others
    monkeypatch.setattr(APPO, "step_delays", [0.05, 0.005, 0.005, 0.005])
    grab = Grab()
    epochs = 20  # 80 fragments; a synchronous runner pool would need 20 x 0.4 s = 8 s of sleeping alone
    start = time.monotonic()
    Runner().load(config(tmp_path, max_epochs=epochs, **{"appo.max_policy_lag": 8})).train(callbacks=[grab])
    seconds = time.monotonic() - start
    assert seconds < 0.5 * epochs * 0.4 + 2.0, seconds  # at least twice the straggler's pace (+ run setup)


@pytest.mark.timeout(60)
def test_hung_runner_is_replaced_while_the_others_deliver(tmp_path):
    runners = EnvRunnersConfig(num_workers=2)
    recipe = EnvRecipe.capture("CartPole-v1", {}, "auto")
    # runner 0 takes 10 s a step: hung for a 1 s fragment timeout; each replacement hangs as well
    pool = LocalRunners(recipe, worker_slices(4, runners), 0, 4, 4, 10, 1.0, [10.0, 0.0])
    try:
        model = build_model(parse_params(config(tmp_path)), pool, torch.device("cpu"))
        pool.start(model, {k: v.clone() for k, v in model.state_dict().items()}, 0)
        got, deadline = [], time.monotonic() + 3.5
        while time.monotonic() < deadline:
            fragment = pool.get(0.1)
            if fragment is not None:
                got.append(fragment.worker)
        assert pool.restarts[0] >= 2 and pool.restarts[1] == 0 and pool.lost_fragments == pool.restarts[0]
        assert len(got) >= 4 and set(got) == {1}
    finally:
        start = time.monotonic()
        pool.close()
        assert time.monotonic() - start < 3.0  # a runner in its step delay wakes up to stop


@pytest.mark.timeout(120)
def test_adaptive_lr_kl_measures_the_update_not_the_policy_lag(tmp_path, monkeypatch):
    """The KL behind the adaptive lr starts from the learner's policy at the start of the update: were it
    the behaviour policy, the runners' lag alone would read as a large step and drive the lr to min_lr."""
    from rlchain.algos.ppo.agent import PPOAgent

    gaps, lags, original = [], [], PPOAgent.update

    def spy(self, storage, progress):
        with torch.no_grad():
            params, _, _ = self.model.evaluate(storage.obs.reshape(-1, *storage.obs.shape[2:]))
        gaps.append(float((params - storage.params.reshape(params.shape)).abs().max()))
        return original(self, storage, progress)

    monkeypatch.setattr(PPOAgent, "update", spy)
    grab = Grab()
    Runner().load(config(tmp_path, normalize_input=False, max_epochs=5)).train(callbacks=[grab])
    lags = [s["policy_lag"] for s in grab.stats]
    assert len(gaps) == 5 and max(gaps) < 1e-5, gaps
    assert max(lags) > 0  # the batches did come from older policies


@pytest.mark.timeout(120)
@pytest.mark.parametrize("mode", ["any", "last"])
def test_runners_report_task_success(tmp_path, mode):
    """TestGoalReach-v0 reports info['success'] inside the runners: APPO's epoch stats and TensorBoard
    get a success rate, counted with the config's success_mode, and log_info_keys' env_info/success."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    raw = config(tmp_path, env_name="TestGoalReach-v0", success_mode=mode, max_epochs=4, log_info_keys=["success"],
                 env_config={"goal_dict": False, "reward_type": "dense", "max_steps": 8})
    raw["params"]["model"] = {"name": "continuous_a2c_logstd"}
    raw["params"]["network"]["space"] = {"continuous": {"fixed_sigma": True}}
    class Episodes(Callback):
        rates: list = []

        def on_epoch_end(self, ctx, stats, episodes):
            if episodes is not None and "success" in episodes:
                self.rates.append(episodes["success"])

    result = Runner().load(raw).train(callbacks=[Episodes()])
    assert result.epoch == 4
    assert Episodes.rates and all(0.0 <= r <= 1.0 for r in Episodes.rates)
    events = EventAccumulator(glob.glob(f"{result.run_dir}/summaries")[0])
    events.Reload()
    assert "episodes/success_rate" in events.Tags()["scalars"]
    step_success = [e.value for e in events.Scalars("env_info/success")]  # log_info_keys, from the runners
    assert len(step_success) == 4 and all(0.0 <= v <= 1.0 for v in step_success)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("algo", ["appo", "impala"])
def test_recurrent_policy_trains_plays_and_resumes(tmp_path, algo):
    """An LSTM policy: the runners carry its state across fragments, the learner trains seq_length sequences."""
    raw = config(tmp_path, algo, max_epochs=2, seq_length=4, **{"env_runners.num_workers": 2})
    raw["params"]["network"]["rnn"] = {"name": "lstm", "units": 8}
    if algo == "impala":
        del raw["params"]["config"]["mini_epochs"]
    grab = Grab()
    result = Runner().load(raw).train(callbacks=[grab])
    assert result.epoch == 2 and result.frames >= 2 * 64
    assert all(torch.isfinite(torch.tensor([s["a_loss"], s["c_loss"]])).all() for s in grab.stats)
    last = f"{result.run_dir}/nn/last_a.pth"
    assert Runner().load(raw).play(checkpoint=last, games=2, quiet=True).games == 2
    raw["params"]["config"]["max_epochs"] = 3
    assert Runner().load(raw).train(checkpoint=last).epoch == 3


@pytest.mark.timeout(120)
def test_kl_penalty_measures_against_a_target_refreshed_every_interval(tmp_path, monkeypatch):
    """kl_loss_coef: the batch's reference params are the target policy's, a copy of the learner's made every
    target_update_interval (3) updates: equal to the learner's before updates 1 and 4 only. The coefficient
    adapts after every pass (2 per update): with a KL always below half the target it halves 10 times in 5."""
    from rlchain.algos.appo.agents import APPOAgent

    gaps, original = [], APPOAgent.update

    def spy(self, storage, progress):
        with torch.no_grad():
            params, _, _ = self.model.evaluate(storage.obs.reshape(-1, *storage.obs.shape[2:]))
        gaps.append(float((params - storage.params.reshape(params.shape)).abs().max()))
        return original(self, storage, progress)

    monkeypatch.setattr(APPOAgent, "update", spy)
    grab = Grab()
    raw = config(tmp_path, normalize_input=False, max_epochs=5, mini_epochs=2, kl_loss_coef=0.5,
                 kl_loss_target=1e9, target_update_interval=3)
    result = Runner().load(raw).train(callbacks=[grab])
    assert [g < 1e-6 for g in gaps] == [True, False, False, True, False], gaps
    assert grab.stats[-1]["kl_coef"] == pytest.approx(0.5 * 0.5 ** 10)
    state = checkpoint.load(f"{result.run_dir}/nn/last_a.pth")  # the target and the live coefficient resume
    assert state["agent"]["kl_coef"] == pytest.approx(0.5 * 0.5 ** 10)
    assert state["kl_target_policy"].keys() == state["model"].keys()
