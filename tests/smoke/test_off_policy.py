"""Shipped SAC / DQN configs for a couple of epochs: train -> play -> resume, and bad config values."""

import glob
import importlib.util
import os

import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt
from rlchain.training.events import Callback
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke

CASES = [("sac_pendulum.yaml", "pendulum_sac", 200), ("dqn_cartpole.yaml", "cartpole_dqn", 400)]
SHIPPED = [*CASES, ("sac_cartpole.yaml", "cartpole_sac", 200)]  # SAC on Discrete actions too


def small(tmp_path, epochs=2, extra=()):
    # warmup shortened so the second epoch already learns
    return [f"params.config.max_epochs={epochs}", f"params.config.train_dir={tmp_path}/runs",
            "params.config.save_best_after=0", "params.config.score_to_win=100000",
            "params.config.num_warmup_frames=100", "params.config.batch_size=32", *extra]


@pytest.mark.parametrize("config,name,frames_per_epoch", SHIPPED)
def test_train_play_resume(tmp_path, capsys, config, name, frames_per_epoch):
    cfg = os.path.join(CONFIGS, config)
    result = Runner().load(cfg, small(tmp_path)).train()
    assert result.epoch == 2 and result.frames == 2 * frames_per_epoch
    out = capsys.readouterr().out
    assert "epoch 2/2" in out and "epoch 1/2" in out
    last = os.path.join(result.run_dir, "nn", f"last_{name}.pth")
    assert os.path.isfile(last)
    assert glob.glob(os.path.join(result.run_dir, "summaries", "events.out.tfevents.*"))
    state = ckpt.load(last)
    assert state["algo"] in ("sac", "dqn") and state["agent"]["updates"] > 0
    assert "replay_buffer" not in state  # off by default

    played = Runner().load(cfg).play(last, games=1)
    assert played.games == 1
    # the checkpoint carries its config
    assert Runner().load_from_checkpoint(last).play(last, games=1, quiet=True).games == 1

    if importlib.util.find_spec("onnxruntime") is not None:  # export checks onnxruntime parity itself
        assert os.path.isfile(Runner().load(cfg).export(last, str(tmp_path / "policy.onnx")))

    resumed = Runner().load(cfg, small(tmp_path, epochs=3)).train(checkpoint=last)
    out = capsys.readouterr().out
    assert "at epoch 2" in out and "epoch 3/3" in out and "epoch 1/3" not in out
    assert resumed.epoch == 3 and resumed.frames == 3 * frames_per_epoch
    assert ckpt.load(os.path.join(resumed.run_dir, "nn", f"last_{name}.pth"))["agent"]["updates"] > \
        state["agent"]["updates"]


def test_sac_resume_with_replay_buffer(tmp_path):
    cfg = os.path.join(CONFIGS, "sac_pendulum.yaml")
    extra = ["params.config.save_replay_buffer=true"]
    result = Runner().load(cfg, small(tmp_path, 1, extra)).train()
    last = os.path.join(result.run_dir, "nn", "last_pendulum_sac.pth")
    state = ckpt.load(last)
    assert state["replay_buffer"]["size"] == 200
    runner = Runner().load(cfg, small(tmp_path, 2, extra))
    captured = {}

    class BufferSize(Callback):
        def on_epoch_end(self, ctx, stats, episodes):
            captured.setdefault("size", len(ctx.algorithm.buffer))

    runner.train(checkpoint=last, callbacks=[BufferSize()])
    assert captured["size"] == 400


def test_sac_tensorboard_tags(tmp_path):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    cfg = os.path.join(CONFIGS, "sac_pendulum.yaml")
    # a Pendulum episode is 200 steps: 4 epochs of 50 steps end the first ones
    result = Runner().load(cfg, small(tmp_path, 4, ["params.config.print_stats=false"])).train()
    acc = EventAccumulator(os.path.join(result.run_dir, "summaries"))
    acc.Reload()
    tags = set(acc.Tags()["scalars"])
    assert {"losses/actor_loss", "losses/critic_loss", "info/alpha", "info/last_lr", "rewards/step",
            "rewards/iter", "episode_lengths/step", "performance/step_fps"} <= tags


def test_dqn_prioritized_nstep_runs(tmp_path):
    cfg = os.path.join(CONFIGS, "dqn_cartpole.yaml")
    result = Runner().load(cfg, small(tmp_path, 2, ["params.config.prioritized_replay=true",
                                                    "params.config.n_step=3",
                                                    "params.config.print_stats=false"])).train()
    assert result.epoch == 2


def test_sac_deterministic_play_repeats(tmp_path):
    cfg = os.path.join(CONFIGS, "sac_pendulum.yaml")
    result = Runner().load(cfg, small(tmp_path, 1, ["params.config.print_stats=false"])).train()
    last = os.path.join(result.run_dir, "nn", "last_pendulum_sac.pth")
    runner = Runner().load(cfg)
    r1 = runner.play(last, games=1, deterministic=True, quiet=True)
    r2 = runner.play(last, games=1, deterministic=True, quiet=True)
    assert r1.rewards == r2.rewards  # same env seed + deterministic policy -> same episode


@pytest.mark.parametrize("config", ["sac_pendulum.yaml", "dqn_cartpole.yaml"])
@pytest.mark.parametrize("override,path,text", [
    ("params.config.batch_size=-4", "params.config.batch_size", "must be > 0"),
    ("params.config.batch_sise=4", "params.config.batch_sise", "did you mean 'batch_size'"),
    ("params.config.replay_buffer_size=16", "params.config.batch_size", "larger than replay_buffer_size"),
    ("params.config.gamma=1.5", "params.config.gamma", "between 0 and 1"),
])
def test_bad_values_name_the_key(config, override, path, text):
    with pytest.raises(ConfigError) as info:
        Runner().load(os.path.join(CONFIGS, config), [override])
    assert info.value.path == path and text in str(info.value)


@pytest.mark.parametrize("override,path", [
    ("params.config.actor_lr=0", "params.config.actor_lr"),
    ("params.config.critic_tau=2", "params.config.critic_tau"),
    ("params.config.log_std_bounds=[2, -5]", "params.config.log_std_bounds"),
    ("params.network.log_std_bounds=[1]", "params.network.log_std_bounds"),
    ("params.config.learnin_rate=1e-3", "params.config.learnin_rate"),  # a typo of a DQN/PPO key
])
def test_bad_sac_values(override, path):
    with pytest.raises(ConfigError) as info:
        Runner().load(os.path.join(CONFIGS, "sac_pendulum.yaml"), [override])
    assert info.value.path == path


def test_a_key_of_another_algo_is_ignored_with_a_warning():
    """learning_rate is DQN's and PPO's: SAC (actor_lr, critic_lr) ignores it with a one-line warning."""
    from rlchain.config import compat
    with pytest.warns(compat.RlchainDeprecationWarning, match="params.config.learning_rate: a key of algo .*dqn"
                                                              ".*, ignored by algo sac"):
        params = Runner().load(os.path.join(CONFIGS, "sac_pendulum.yaml"), ["params.config.learning_rate=2e-3"]).params
    assert not hasattr(params.config, "learning_rate")


def test_wrong_action_space_is_a_clear_error(tmp_path):
    cfg = os.path.join(CONFIGS, "sac_pendulum.yaml")
    with pytest.raises(ConfigError, match="Box or Discrete"):
        Runner().load(cfg, ["params.config.env_name=TestMultiDiscrete-v0", *small(tmp_path, 1)]).train()


def test_torch_seeded_runs_repeat(tmp_path):
    cfg = os.path.join(CONFIGS, "dqn_cartpole.yaml")
    weights = []
    for i in range(2):
        extra = [f"params.config.full_experiment_name=r{i}", "params.config.print_stats=false"]
        res = Runner().load(cfg, small(tmp_path, 2, extra)).train()
        weights.append(torch.load(os.path.join(res.run_dir, "nn", "last_cartpole_dqn.pth"),
                                  weights_only=False)["model"]["network.advantage.weight"])
    assert torch.equal(weights[0], weights[1])


DIVERGE = {"sac_pendulum.yaml": ("params.config.actor_lr=1e30", "params.config.critic_lr=1e30"),
           "dqn_cartpole.yaml": ("params.config.learning_rate=1e30",)}


@pytest.mark.parametrize("config,name,frames_per_epoch", CASES)
def test_absurd_learning_rate_stops_without_nan_checkpoints(tmp_path, config, name, frames_per_epoch):
    from rlchain.errors import DivergenceError
    cfg = os.path.join(CONFIGS, config)
    with pytest.raises(DivergenceError, match=r"training diverged at epoch \d+: .*non-finite"):
        Runner().load(cfg, small(tmp_path, 6, DIVERGE[config])).train()
    for path in glob.glob(str(tmp_path / "runs" / "*" / "nn" / "*.pth")):
        assert all(torch.isfinite(v).all() for v in ckpt.load(path)["model"].values() if v.is_floating_point())


@pytest.mark.parametrize("config,name,frames_per_epoch", CASES)
def test_absurd_learning_rate_rolls_back_to_the_snapshot(tmp_path, capsys, config, name, frames_per_epoch):
    cfg = os.path.join(CONFIGS, config)
    extra = (*DIVERGE[config], "params.config.divergence.action=rollback", "params.config.snapshot_epochs=2",
             "params.config.divergence.max_rollbacks=3", "params.config.divergence.lr_factor=1e-33")
    result = Runner().load(cfg, small(tmp_path, 6, extra)).train()
    assert result.epoch == 6
    out = capsys.readouterr().out
    assert "rolled back to epoch 0 (1/3)" in out  # the snapshot before learning started
    last = ckpt.load(os.path.join(result.run_dir, "nn", f"last_{name}.pth"))
    assert all(torch.isfinite(v).all() for v in last["model"].values() if v.is_floating_point())
