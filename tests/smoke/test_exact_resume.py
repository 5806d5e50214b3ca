"""Exact resume: N epochs + resume to 2N is bit-identical to 2N straight -- parameters, optimizer
state, every logged epoch metric and episode reward -- for PPO on gymnasium (native, sync, async; classic
control and MuJoCo), a torch tensor env, SAC with its replay buffer saved, a SIGTERM in the middle of an
epoch and the periodic / best checkpoints; envs that cannot give their state resume as before with one line.

Threads are pinned (torch_threads / update_threads 1): rlchain picks thread counts from the machine's load,
and a forward over a different thread count may round differently, which no checkpoint could restore.
"""

import glob
import logging
import os
import signal
import time

import gymnasium as gym
import pytest
import torch

from rlchain import Runner
from rlchain.runs import checkpoint as ckpt
from rlchain.training.events import Callback
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke
CARTPOLE = ("ppo_cartpole.yaml", ["params.network.mlp.units=[16]", "params.config.num_actors=4",
                                  "params.config.minibatch_size=32"])
TIMING = ("seconds", "fps", "time")


class Record(Callback):
    """Every epoch's metrics (timings left out) and episode statistics, as the loop logs them."""

    def __init__(self, sigterm_at_step=None):
        self.epochs, self.steps, self.sigterm_at_step = {}, 0, sigterm_at_step

    def on_epoch_end(self, ctx, stats, episodes):
        kept = {k: v for k, v in stats.items() if not any(t in k for t in TIMING)}
        self.epochs[ctx.state.epoch] = (kept, dict(episodes) if episodes else None)

    def on_env_step(self, ctx, result, done_indices, rows):
        self.steps += 1
        if self.steps == self.sigterm_at_step:
            os.kill(os.getpid(), signal.SIGTERM)  # the run stops after this env step, mid-epoch


def train(tmp_path, name, config, overrides, epochs, checkpoint=None, record=None, extra=()):
    over = [*overrides, f"params.config.max_epochs={epochs}", f"params.config.train_dir={tmp_path / name}",
            "params.config.score_to_win=1e9", "params.config.print_stats=false", "params.torch_threads=1",
            "params.update_threads=1", *extra]
    record = record or Record()
    result = Runner().load(os.path.join(CONFIGS, config), over).train(checkpoint=checkpoint, callbacks=[record])
    return result, record


def last(result):
    return glob.glob(os.path.join(result.run_dir, "nn", "last_*.pth"))[0]


def assert_same(a, b, where="state"):
    """Nested dicts / lists / tensors equal bit for bit (torch.equal), not close."""
    if isinstance(a, torch.Tensor):
        assert isinstance(b, torch.Tensor) and a.dtype == b.dtype and torch.equal(a, b), where
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for key in a:
            assert_same(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{i}]")
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


def assert_resumed_equals_straight(straight, resumed, rec_straight, rec_resumed, first_resumed_epoch):
    s, r = ckpt.load(last(straight)), ckpt.load(last(resumed))
    assert s["epoch"] == r["epoch"] and s["frames"] == r["frames"]
    assert_same(s["model"], r["model"], "model")
    assert_same(s["agent"], r["agent"], "agent (optimizer, lr)")
    assert_same(s["episodes"], r["episodes"], "finished episodes")
    assert_same(s["run_state"]["running"], r["run_state"]["running"], "episodes in progress")
    assert "replay_buffer" not in s or assert_same(s["replay_buffer"], r["replay_buffer"], "replay") is None
    later = {e: v for e, v in rec_straight.epochs.items() if e >= first_resumed_epoch}
    assert later and later == rec_resumed.epochs  # every logged metric and episode reward, exactly


def check_split(tmp_path, config, overrides, n, extra=()):
    straight, rec_s = train(tmp_path, "straight", config, overrides, 2 * n, extra=extra)
    half, _ = train(tmp_path, "half", config, overrides, n, extra=extra)
    resumed, rec_r = train(tmp_path, "resumed", config, overrides, 2 * n, checkpoint=last(half), extra=extra)
    assert_resumed_equals_straight(straight, resumed, rec_s, rec_r, n + 1)
    return ckpt.load(last(half))


@pytest.mark.parametrize("vecenv_type", ["auto", "async"])  # auto: gymnasium's native CartPole vector env
def test_ppo_cartpole_resume_is_bit_identical(tmp_path, vecenv_type):
    config, overrides = CARTPOLE
    half = check_split(tmp_path, config, [*overrides, f"params.config.vecenv_type={vecenv_type}"], 6)
    assert half["run_state"]["env"] is not None


def test_ppo_pendulum_and_halfcheetah_resume_is_bit_identical(tmp_path):
    check_split(tmp_path / "pendulum", "ppo_pendulum.yaml",
                ["params.network.mlp.units=[16]", "params.config.num_actors=2", "params.config.horizon_length=32",
                 "params.config.minibatch_size=32", "params.config.mini_epochs=2",
                 "params.config.env_config={max_episode_steps: 40}"], 3)  # episodes end inside both halves
    check_split(tmp_path / "cheetah", "ppo_halfcheetah.yaml",
                ["params.config.env_name=HalfCheetah-v5", "params.config.env_config={max_episode_steps: 24}",
                 "params.config.vecenv_type=sync", "params.network.mlp.units=[16]", "params.config.num_actors=2",
                 "params.config.horizon_length=16", "params.config.minibatch_size=32",
                 "params.config.mini_epochs=1"], 2)


def test_ppo_tensor_env_resume_is_bit_identical(tmp_path):
    check_split(tmp_path, "ppo_torch_cartpole.yaml",
                ["params.network.mlp.units=[16]", "params.config.num_actors=16", "params.config.minibatch_size=64"], 4)


def test_sac_resume_with_the_replay_buffer_is_bit_identical(tmp_path, caplog):
    overrides = ["params.network.mlp.units=[16]", "params.config.num_actors=2", "params.config.num_steps_per_episode=8",
                 "params.config.num_warmup_frames=32", "params.config.batch_size=16",
                 "params.config.replay_buffer_size=64",  # wraps around inside the run
                 "params.config.save_replay_buffer=true"]
    with caplog.at_level(logging.INFO, logger="rlchain"):
        check_split(tmp_path, "sac_pendulum.yaml", overrides, 4)
    said = [r.getMessage() for r in caplog.records if r.getMessage().startswith("save_replay_buffer:")]
    # once per run (straight, half, resumed): 64 x (obs 3 + next 3 + action, reward, discount) x 4 B + 2 flags
    assert said == ["save_replay_buffer: checkpoints carry the replay buffer, 64 transitions now (2.4 KiB; 2.4 KiB "
                    "when full at 64)"] * 3


def test_sigterm_mid_epoch_resumes_bit_identically(tmp_path):
    config, overrides = CARTPOLE
    straight, rec_s = train(tmp_path, "straight", config, overrides, 8)
    # 16 steps per epoch: the SIGTERM comes at step 6 of epoch 4, which is then not counted
    stopped, _ = train(tmp_path, "stopped", config, overrides, 8, record=Record(sigterm_at_step=3 * 16 + 6))
    assert stopped.stop_reason == "interrupted by SIGTERM" and stopped.epoch == 3
    resumed, rec_r = train(tmp_path, "resumed", config, overrides, 8, checkpoint=last(stopped))
    assert_resumed_equals_straight(straight, resumed, rec_s, rec_r, 4)


class SigtermInUpdate(Record):
    """SIGTERM between the 2nd and 3rd minibatch of the update after epoch ``epoch`` (through the PPO agent's
    stop check, which runs before every minibatch); counts the minibatches run after it and the seconds
    from the signal to the end of the run."""

    def __init__(self, epoch, agent="agent"):
        super().__init__()
        self.epoch, self.agent, self.checks, self.after, self.sent = epoch, agent, 0, 0, None

    def on_train_start(self, ctx):
        agent = getattr(ctx.algorithm, self.agent)
        check = agent.should_stop

        def counted():
            if ctx.state.epoch == self.epoch:
                self.checks += 1
                if self.checks == 3:
                    self.sent = time.monotonic()
                    os.kill(os.getpid(), signal.SIGTERM)
                elif self.sent is not None:
                    self.after += 1
            return check()
        agent.should_stop = counted

    def on_epoch_end(self, ctx, stats, episodes):
        kept = {k: v for k, v in stats.items() if not any(t in k for t in TIMING)}
        self.epochs[ctx.state.epoch] = (kept, dict(episodes) if episodes else None)

    def on_train_end(self, ctx, result):
        self.seconds = time.monotonic() - self.sent if self.sent else None


CENTRAL_VALUE = ["params.config.env_name=ObsStateCartPoleTest-v0", "params.config.central_value_config={network: "
                 "{name: actor_critic, central_value: True, mlp: {units: [16]}}, mini_epochs: 2}"]


@pytest.mark.parametrize("agent", ["agent", "cv_agent"])  # the actor's update; the central value's, after it
def test_sigterm_mid_update_stops_between_minibatches_and_resumes_bit_identically(tmp_path, agent):
    config, overrides = CARTPOLE
    if agent == "cv_agent":
        import tests.smoke.obs_state_cartpole  # noqa: F401  (registers ObsStateCartPoleTest-v0)
        overrides = [*overrides, *CENTRAL_VALUE]
    straight, rec_s = train(tmp_path, "straight", config, overrides, 8)
    record = SigtermInUpdate(epoch=3, agent=agent)  # the update of epoch 4 is left after 2 of its minibatches
    stopped, _ = train(tmp_path, "stopped", config, overrides, 8, record=record)
    assert stopped.stop_reason == "interrupted by SIGTERM" and stopped.epoch == 3
    assert record.sent is not None and record.after == 0  # not one more minibatch after the signal
    assert record.seconds < 1.0
    resumed, rec_r = train(tmp_path, "resumed", config, overrides, 8, checkpoint=last(stopped))
    assert_resumed_equals_straight(straight, resumed, rec_s, rec_r, 4)


def test_periodic_and_best_checkpoints_resume_bit_identically(tmp_path):
    config, overrides = CARTPOLE
    straight, rec_s = train(tmp_path, "straight", config, overrides, 8,
                            extra=["params.config.save_frequency=3", "params.config.save_best_after=2"])
    nn = os.path.join(straight.run_dir, "nn")
    best = ckpt.load(os.path.join(nn, "cartpole.pth"))
    for path in (os.path.join(nn, "cartpole_ep_3.pth"), os.path.join(nn, "cartpole.pth")):
        start = ckpt.load(path)["epoch"]
        resumed, rec_r = train(tmp_path, f"from_{os.path.basename(path)}", config, overrides, 8, checkpoint=path,
                               extra=["params.config.save_frequency=3", "params.config.save_best_after=2"])
        assert_resumed_equals_straight(straight, resumed, rec_s, rec_r, start + 1)
    assert 2 <= best["epoch"] <= 8


def test_an_env_without_state_resumes_as_before_with_one_line(tmp_path, caplog):
    pytest.importorskip("envpool")
    overrides = ["params.network.mlp.units=[16]", "params.config.num_actors=4", "params.config.minibatch_size=32",
                 "params.config.vecenv_type=envpool"]
    half, _ = train(tmp_path, "half", "ppo_cartpole.yaml", overrides, 2)
    assert ckpt.load(last(half))["run_state"]["env"] is None
    with caplog.at_level(logging.WARNING, logger="rlchain"):
        resumed, _ = train(tmp_path, "resumed", "ppo_cartpole.yaml", overrides, 3, checkpoint=last(half))
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("resume:")]
    assert lines == ["resume: CartPole-v1 (EnvpoolVecEnv) starts new episodes: the checkpoint holds no env state "
                     "(the env has no get_state / set_state); the learner, counters, random streams and "
                     "finished-episode statistics are restored"]
    assert resumed.epoch == 3


class Handle:
    """What an env may hold that rlchain cannot read (an emulator, a physics engine)."""


class OpaqueCartPole(gym.Wrapper):
    """CartPole holding an unreadable handle: its state cannot be saved."""

    def __init__(self):
        super().__init__(gym.make("CartPole-v1"))
        self.engine = Handle()


def test_an_env_whose_state_cannot_be_read_is_named_once_and_resumes_as_before(tmp_path, caplog):
    if "OpaqueCartPole-v0" not in gym.registry:
        gym.register("OpaqueCartPole-v0", entry_point=OpaqueCartPole)
    overrides = ["params.network.mlp.units=[16]", "params.config.num_actors=4", "params.config.minibatch_size=32",
                 "params.config.env_name=OpaqueCartPole-v0", "params.config.vecenv_type=sync"]
    with caplog.at_level(logging.WARNING, logger="rlchain"):
        half, _ = train(tmp_path, "half", "ppo_cartpole.yaml", overrides, 2)
        resumed, _ = train(tmp_path, "resumed", "ppo_cartpole.yaml", overrides, 3, checkpoint=last(half))
    said = [r.getMessage() for r in caplog.records]
    assert said[0] == ("warning: checkpoints will not hold the state of OpaqueCartPole-v0 (GymnasiumVecEnv): "
                       "OpaqueCartPole-v0: env 0 (OpaqueCartPole) holds 'engine' of type Handle, which rlchain cannot "
                       "snapshot; a resume restarts its episodes")
    resume = [line for line in said if line.startswith("resume:")]
    assert len(resume) == 1 and "OpaqueCartPole-v0 (GymnasiumVecEnv) starts new episodes: the checkpoint holds no " \
                                "env state (OpaqueCartPole-v0: env 0 (OpaqueCartPole) holds 'engine'" in resume[0]
    assert resumed.epoch == 3 and ckpt.load(last(half))["run_state"]["env"] is None
