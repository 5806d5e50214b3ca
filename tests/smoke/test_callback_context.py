"""Callbacks get a CallbackContext (typed state, request_stop, save, set_params, model / writer / env
spec / algorithm), the run's parts read directly, never the loop; rl_games AlgoObservers' after_init(algo)
gets the attributes observers read of rl_games' algo."""

import dataclasses
import math
import os

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


def test_the_context_reads_the_runs_parts_and_forwards_nothing(tmp_path):
    inspect = Inspect()
    Runner().load(CARTPOLE, small(tmp_path, epochs=3, extra=QUIET)).train(callbacks=[inspect])
    ctx = inspect.ctx
    assert type(ctx.algorithm).__name__ == "PPO" and ctx.agent is ctx.algorithm.agent
    assert ctx.model is ctx.algorithm.model and ctx.training_env.num_envs == ctx.env_spec.num_envs == 32
    assert ctx.frames_per_epoch() == 512 and ctx.run_dir.root == ctx.state.experiment_dir
    assert ctx.full_state()["epoch"] == 2 and set(ctx.get_params()) >= {"learning_rate"}
    for name in ("epoch", "frames", "cfg", "trainer", "_trainer"):  # the loop's attributes are not the context's
        assert not hasattr(ctx, name), name


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
