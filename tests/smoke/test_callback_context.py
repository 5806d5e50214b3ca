"""Callbacks get a CallbackContext (typed state, request_stop, save, set_params, model / writer / env
spec), not the trainer; old callbacks' trainer attribute reads still work with a DeprecationWarning;
rl_games AlgoObservers' after_init(algo) gets the attributes observers read of rl_games' algo."""

import dataclasses
import math
import os
import warnings

import pytest
import torch

from rlchain import Runner
from rlchain.training.callback_context import CallbackContext, EnvSpec, TrainingState
from rlchain.training.events import Callback
from tests.conftest import CONFIGS
from tests.smoke.test_train_play_resume import small

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
QUIET = ["params.config.print_stats=false"]


def scalars(run_dir, tag):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
    acc = EventAccumulator(os.path.join(run_dir, "summaries"))
    acc.Reload()
    return [(e.step, e.value) for e in acc.Scalars(tag)] if tag in acc.Tags()["scalars"] else []


class Inspect(Callback):
    """Reads the state at each event, writes a scalar, saves a checkpoint of its own and stops at epoch 2."""

    def __init__(self):
        self.states, self.saved, self.spec, self.ctx = [], None, None, None

    def on_train_start(self, ctx):
        self.ctx, self.spec = ctx, ctx.env_spec
        self.states.append(ctx.state)

    def on_epoch_end(self, ctx, stats, episodes):
        state = ctx.state
        self.states.append(state)
        ctx.writer.add_scalar("custom/epoch_squared", state.epoch ** 2, state.frames)
        if state.epoch == 2:
            self.saved = ctx.save("ep_mine")
            ctx.request_stop("inspect")


def test_callbacks_get_a_typed_state_and_their_actions(tmp_path):
    inspect = Inspect()
    result = Runner().load(CARTPOLE, small(tmp_path, epochs=50, extra=QUIET)).train(seed=5, callbacks=[inspect])
    assert result.stop_reason == "stopped by request: inspect" and result.epoch == 2  # the epoch it asked in
    assert isinstance(inspect.ctx, CallbackContext)
    start, first, *_, last = inspect.states
    assert isinstance(start, TrainingState)
    assert (start.epoch, start.frames, start.stats, start.episodes) == (0, 0, {}, None)
    assert start.best_reward == -math.inf and start.algo == "a2c_discrete" and start.name == "cartpole"
    assert (first.epoch, first.frames) == (1, 512) and (last.epoch, last.frames) == (2, 1024)
    assert "kl" in first.stats and first.seconds > 0 and last.seconds >= first.seconds
    assert last.episodes is not None and last.best_reward == max(s.episodes["reward"] for s in inspect.states[1:]
                                                                   if s.episodes)
    assert last.experiment_dir == result.run_dir and last.device == torch.device("cpu") and last.seed == 5
    assert (last.rank, last.world_size, last.is_main, last.max_epochs) == (0, 1, True, 50)
    with pytest.raises(dataclasses.FrozenInstanceError):
        last.epoch = 7
    with pytest.raises(TypeError):
        last.stats["kl"] = 0.0  # a read-only copy
    spec = inspect.spec
    assert isinstance(spec, EnvSpec) and (spec.num_envs, spec.num_agents, spec.tensor_native) == (32, 1, False)
    assert inspect.spec.action_space.n == 2
    assert inspect.saved == os.path.join(result.run_dir, "nn", "cartpole_ep_mine.pth")
    assert os.path.isfile(inspect.saved)
    assert scalars(result.run_dir, "custom/epoch_squared") == [(512, 1.0), (1024, 4.0)]
    with pytest.raises(ValueError, match="callbacks may emit on_evaluation or on_stats_cleared, not 'on_train_end'"):
        inspect.ctx.emit("on_train_end", result)


class OldStyle(Callback):
    """A callback written for the trainer: reads and sets its attributes."""

    def __init__(self):
        self.seen = []

    def on_epoch_end(self, trainer, stats, episodes):
        self.seen.append((trainer.epoch, trainer.frames, trainer.cfg.name, type(trainer.agent).__name__))
        trainer.marked = trainer.epoch


def test_old_callbacks_reading_the_trainer_still_work_with_a_deprecation_warning(tmp_path):
    old = OldStyle()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Runner().load(CARTPOLE, small(tmp_path, epochs=2, extra=QUIET)).train(callbacks=[old])
    assert old.seen == [(1, 512, "cartpole", "PPOAgent"), (2, 1024, "cartpole", "PPOAgent")]
    messages = [str(w.message) for w in caught if issubclass(w.category, DeprecationWarning)]
    named = sorted(m.split("'")[1] for m in messages if "CallbackContext, not the trainer" in m)
    # once each; the agent is one of the context's own handles (rl_games' observers read its optimizer)
    assert named == ["trainer.cfg", "trainer.epoch", "trainer.frames", "trainer.marked"]
    assert all(w.filename == __file__ for w in caught if "CallbackContext" in str(w.message))  # points at the callback


def test_a_context_attribute_the_trainer_lacks_is_an_attribute_error():
    ctx = CallbackContext(type("Trainer", (), {"epoch": 1})())
    with pytest.raises(AttributeError, match="a callback context has no attribute 'nope'"):
        ctx.nope  # noqa: B018
    with pytest.warns(DeprecationWarning, match=r"'trainer.epoch' is deprecated"):
        assert ctx.epoch == 1


class ReadsAlgo:
    """An rl_games AlgoObserver as IsaacGymEnvs-style observers write them: keeps algo and its writer."""

    def __init__(self):
        self.init, self.printed = None, []

    def after_init(self, algo):
        self.algo, self.writer = algo, algo.writer
        self.init = (algo.ppo_device, algo.device, algo.games_to_track, algo.epoch_num, algo.frame,
                     algo.num_actors, algo.num_agents, algo.config["name"], algo.experiment_dir)

    def after_print_stats(self, frame, epoch_num, total_time):
        self.writer.add_scalar("observer/epoch", epoch_num, frame)
        self.printed.append((self.algo.epoch_num, self.algo.frame, frame, epoch_num))


def test_algo_observer_after_init_gets_writer_device_and_counters(tmp_path):
    observer = ReadsAlgo()
    result = Runner().load(CARTPOLE, small(tmp_path, epochs=2, extra=QUIET)).train(callbacks=[observer])
    cpu = torch.device("cpu")
    assert observer.init == (cpu, cpu, 100, 0, 0, 32, 1, "cartpole", result.run_dir)
    assert observer.printed == [(1, 512, 512, 1), (2, 1024, 1024, 2)]  # live counters
    assert scalars(result.run_dir, "observer/epoch") == [(512, 1.0), (1024, 2.0)]
