"""Events, config-named callbacks, rl_games AlgoObserver adapter and in-training evaluation."""

import os
import types

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner, env_configurations
from rlchain.algos.base.context import RunContext
from rlchain.config import ConfigError
from rlchain.envs.vecenv import DROPPED, StepResult
from rlchain.training.events import AlgoObserverCallback, Callback, CallbackList
from tests.conftest import CONFIGS
from tests.smoke.test_train_play_resume import small
from tests.unit.test_self_play import keep_self_play

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
SEEN = []


class Countdown(gym.Env):
    """Episodes of ``2 + seed % 3`` steps, the seed of its first seeded reset (env i of a vector
    env reset with seed s gets s + i), so the test knows which envs end at which step."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
    action_space = gym.spaces.Discrete(2)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        if seed is not None:
            self.length = 2 + seed % 3
        self.t = 0
        return np.zeros(2, np.float32), {}

    def step(self, action):
        self.t += 1
        return np.zeros(2, np.float32), 1.0, self.t >= self.length, False, {"t": self.t}


if "Countdown-test" not in gym.registry:
    env_configurations.register("Countdown-test", {"env_creator": lambda **kw: Countdown()})


def countdown_done(seed, num_envs, step):
    """Envs whose episode ends at env step ``step`` (1, 2, ...) of a run seeded ``seed``."""
    return [i for i in range(num_envs) if step % (2 + (seed + i) % 3) == 0]


class StepObserver:
    """An rl_games AlgoObserver with every method, recording the calls."""

    def __init__(self):
        self.calls = []

    def before_init(self, base_name, config, experiment_name):
        self.calls.append("before_init")

    def after_init(self, algo):
        self.calls.append("after_init")

    def process_infos(self, infos, done_indices):
        assert isinstance(infos, dict) and isinstance(done_indices, torch.Tensor)
        assert done_indices.dim() == 2 and done_indices.shape[1] == 1  # as rl_games: dones.nonzero()
        self.calls.append(("process_infos", done_indices.flatten().tolist()))

    def after_steps(self):
        self.calls.append("after_steps")

    def after_clear_stats(self):
        self.calls.append("after_clear_stats")

    def after_print_stats(self, frame, epoch_num, total_time):
        self.calls.append(("after_print_stats", epoch_num))


def expected_calls(seed, num_envs, steps_per_epoch, epochs):
    calls, step = ["before_init", "after_init"], 0
    for epoch in range(1, epochs + 1):
        for _ in range(steps_per_epoch):
            step += 1
            calls.append(("process_infos", countdown_done(seed, num_envs, step)))
        calls += ["after_steps", ("after_print_stats", epoch)]
    return calls


class Recorder(Callback):
    """Records every event it gets (named from YAML in a test below)."""

    def on_train_start(self, ctx):
        SEEN.append(("start", ctx.state.epoch))

    def on_epoch_end(self, ctx, stats, episodes):
        SEEN.append(("epoch", ctx.state.epoch, "kl" in stats))

    def on_evaluation(self, ctx, result):
        SEEN.append(("evaluation", ctx.state.epoch, result.games))

    def on_checkpoint(self, ctx, path, kind):
        SEEN.append(("checkpoint", kind, os.path.isfile(path)))

    def on_train_end(self, ctx, result):
        SEEN.append(("end", result.epoch))


class Observer:
    """The shape of an rl_games AlgoObserver."""

    def __init__(self):
        self.calls = []

    def before_init(self, base_name, config, experiment_name):
        self.calls.append("before_init")

    def after_init(self, algo):
        self.calls.append("after_init")

    def after_print_stats(self, frame, epoch_num, total_time):
        self.calls.append(("after_print_stats", frame, epoch_num))


def test_events_from_config_and_evaluation(tmp_path):
    SEEN.clear()
    runner = Runner().load(CARTPOLE, small(tmp_path, epochs=4, extra=[
        "params.config.callbacks=['tests.smoke.test_events:Recorder']",
        "params.config.evaluation.interval=2", "params.config.evaluation.games=3",
        "params.config.evaluation.select_best=evaluation", "params.config.print_stats=false"]))
    result = runner.train()
    assert SEEN[0] == ("start", 0) and SEEN[-1] == ("end", 4)
    assert [e for e in SEEN if e[0] == "epoch"] == [("epoch", i, True) for i in range(1, 5)]
    assert [e for e in SEEN if e[0] == "evaluation"] == [("evaluation", 2, 3), ("evaluation", 4, 3)]
    kinds = [e[1] for e in SEEN if e[0] == "checkpoint"]
    assert "best" in kinds and kinds[-1] == "last"
    assert all(e[2] for e in SEEN if e[0] == "checkpoint")
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
    acc = EventAccumulator(os.path.join(result.run_dir, "summaries"))
    acc.Reload()
    assert len(acc.Scalars("evaluation/rewards")) == 2


def test_evaluation_and_stop_messages_are_logged_to_stdout(tmp_path, capsys):
    """With print_stats (the default) the evaluation line and the stop line go through the 'rlchain'
    logger to the current stdout (a regression: a local name once hid the logger after evaluation)."""
    result = Runner().load(CARTPOLE, small(tmp_path, epochs=2, extra=[
        "params.config.evaluation.interval=1", "params.config.evaluation.games=2"])).train()
    out = capsys.readouterr().out
    assert result.epoch == 2
    assert "evaluation at epoch 1: reward" in out and "evaluation at epoch 2: reward" in out
    assert "stopped: max_epochs 2 reached at epoch 2" in out


def test_algo_observer_and_function_callbacks(tmp_path):
    observer, epochs = Observer(), []
    Runner().load(CARTPOLE, small(tmp_path, epochs=2, extra=["params.config.print_stats=false"])).train(
        callbacks=[observer, lambda ctx, stats, episodes: epochs.append(ctx.state.epoch)])
    assert observer.calls[:2] == ["before_init", "after_init"]
    assert observer.calls[2:] == [("after_print_stats", 512, 1), ("after_print_stats", 1024, 2)]
    assert epochs == [1, 2]


def test_algo_observer_gets_every_step_with_its_finished_envs(tmp_path):
    """PPO: process_infos after each env step with the envs whose episode ended there, after_steps
    after each rollout, after_print_stats after each epoch; no after_clear_stats without self-play."""
    observer = StepObserver()
    Runner().load(CARTPOLE, small(tmp_path, epochs=2, extra=[
        "params.config.env_name=Countdown-test", "params.config.num_actors=4", "params.config.horizon_length=8",
        "params.config.minibatch_size=32", "params.config.print_stats=false"])).train(seed=3, callbacks=[observer])
    assert observer.calls == expected_calls(seed=3, num_envs=4, steps_per_epoch=8, epochs=2)
    assert ("process_infos", [0, 1, 2, 3]) in observer.calls  # step 12: every length (2, 3, 4) divides it


def test_algo_observer_in_off_policy_training(tmp_path):
    observer = StepObserver()
    Runner().load(os.path.join(CONFIGS, "dqn_cartpole.yaml"), small(tmp_path, epochs=2, extra=[
        "params.config.env_name=Countdown-test", "params.config.num_steps_per_episode=7",
        "params.config.num_warmup_frames=1000000", "params.config.print_stats=false"])).train(
        seed=8, callbacks=[observer])
    assert observer.calls == expected_calls(seed=8, num_envs=4, steps_per_epoch=7, epochs=2)


def test_after_clear_stats_follows_self_play_updates(tmp_path, monkeypatch):
    observer = StepObserver()
    kept = keep_self_play(monkeypatch)
    Runner().load(os.path.join(CONFIGS, "ppo_duel_self_play.yaml"), [
        f"params.config.train_dir={tmp_path}", "params.config.max_epochs=3", "params.config.print_stats=false",
        "params.config.num_actors=4", "params.config.minibatch_size=64",
        "params.config.self_play_config.games_to_check=1", "params.config.self_play_config.update_score=-1",
        "params.config.self_play_config.env_update_num=1"]).train(callbacks=[observer])
    (self_play,) = kept
    assert self_play.updates >= 1
    assert observer.calls.count("after_clear_stats") == self_play.updates
    # as in rl_games, an epoch's statistics are printed before self-play clears them
    for i, call in enumerate(observer.calls):
        if call == "after_clear_stats":
            assert observer.calls[i - 1][0] == "after_print_stats"


class StepRecorder(Callback):
    def __init__(self):
        self.steps = []

    def on_env_step(self, ctx, result, done_indices, rows):
        self.steps.append((done_indices.tolist(), rows))


def test_env_step_done_indices_multi_agent_and_dropped_rows():
    recorder = StepRecorder()
    events = CallbackList([recorder, Callback(), lambda ctx, stats, episodes: None])
    assert events.step_callbacks == [recorder]  # only the callbacks that want steps are called per step
    ctx = types.SimpleNamespace(num_agents=2, events=events)
    dones = torch.tensor([True, True, False, False, True, True, True, True])  # envs 0, 2, 3 ended (2 agents)
    result = StepResult(None, None, None, None, None, {DROPPED: np.array([0, 0, 0, 0, 0, 0, 1, 1], bool)})
    RunContext.emit_env_step(ctx, result, dones, slice(None))
    assert recorder.steps == [([0, 4], slice(None))]  # env 3 was cut by a dead worker, not finished


def test_env_steps_of_a_pipelined_rollout_come_per_group(tmp_path):
    """env_groups: one on_env_step per group and step, rows local to the group; together the same
    episode ends as the synchronous rollout's."""
    pytest.importorskip("envpool")
    from tests.smoke.test_env_groups import envpool_cartpole

    def finished(groups):
        recorder = StepRecorder()
        envpool_cartpole(tmp_path, groups, "params.config.max_epochs=2").train(callbacks=[recorder])
        per_step = {}
        for n, (done, rows) in enumerate(recorder.steps):
            start = rows.start or 0
            per_step.setdefault(n // groups, []).extend(start + i for i in done)
        return recorder.steps, [sorted(v) for _, v in sorted(per_step.items())]

    one_steps, one = finished(1)
    two_steps, two = finished(2)
    assert len(one_steps) == 2 * 32 and len(two_steps) == 2 * 2 * 32
    assert {(rows.start, rows.stop) for _, rows in two_steps} == {(0, 8), (8, 16)}
    assert all(i < 8 for done, _ in two_steps for i in done)
    assert one == two and sum(map(len, one)) > 0


def test_observer_without_process_infos_costs_no_step_hook():
    class PrintOnly:
        def after_print_stats(self, frame, epoch_num, total_time):
            pass

    assert CallbackList([PrintOnly()]).step_callbacks == []
    assert len(CallbackList([StepObserver()]).step_callbacks) == 1
    infos = []

    class ListObserver:
        def process_infos(self, infos_, done_indices):
            infos.append((infos_, done_indices.tolist()))

    adapter = AlgoObserverCallback(ListObserver())
    result = StepResult(None, None, None, None, None, {"env_infos": [{"battle_won": 1}, {}]})
    adapter.on_env_step(None, result, torch.tensor([2]), slice(None))
    assert infos == [([{"battle_won": 1}, {}], [[2]])]  # multi-agent infos as rl_games' list of dicts


def test_bad_callback_name_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match=r"params.config.callbacks\[0\]: module 'tests.smoke.test_events' has no"):
        Runner().load(CARTPOLE, ["params.config.callbacks=['tests.smoke.test_events:Nope']"])
    with pytest.raises(ConfigError, match=r"must look like"):
        Runner().load(CARTPOLE, ["params.config.callbacks=['justaname']"])


def test_get_set_params_during_training(tmp_path, capsys):
    seen = []

    def tweak(ctx, stats, episodes):
        if ctx.state.epoch == 1:
            assert ctx.get_params()["entropy_coef"] == 0.0
            ctx.set_params(learning_rate=1e-4, entropy_coef=0.01, mini_epochs=2)
        seen.append((ctx.state.epoch, ctx.get_params()["learning_rate"], ctx.get_params()["entropy_coef"]))

    Runner().load(CARTPOLE, small(tmp_path, epochs=3, extra=["params.config.print_stats=true",
                                                             "params.config.lr_schedule=None"])).train(
        callbacks=[tweak])
    assert seen[1:] == [(2, pytest.approx(1e-4), 0.01), (3, pytest.approx(1e-4), 0.01)]
    assert "set entropy_coef = 0.01 at epoch 1" in capsys.readouterr().out
    # a quiet run (print_stats false: tune trials, scripts) changes the values without the line
    seen.clear()
    Runner().load(CARTPOLE, small(tmp_path, epochs=2, extra=["params.config.print_stats=false",
                                                             "params.config.lr_schedule=None"])).train(
        callbacks=[tweak])
    assert seen[1:] == [(2, pytest.approx(1e-4), 0.01)]
    assert "set entropy_coef" not in capsys.readouterr().out
    with pytest.raises(KeyError, match="cannot set gamma_typo"):
        from rlchain.algos.ppo.ppo import PPO
        from rlchain.training.live_params import check_tunable
        check_tunable({"gamma_typo": 1}, PPO.tunable)
