"""Checkpoints and the frozen config: a checkpoint stores the resolved config; checkpoints written
before (main at 7e59869, tests/data/*_7e59869.pth) still play and resume; one without a config fails in one
line; live hyperparameters belong to the run and survive a resume."""

import copy
import os

import pytest
import torch

from rlchain import Runner
from rlchain.config.resolve import CONFIG_FORMAT
from rlchain.runs import checkpoint as ckpt
from rlchain.training.events import Callback
from tests.conftest import BASE, CONFIGS, ROOT

pytestmark = pytest.mark.smoke
DATA = os.path.join(ROOT, "tests", "data")
OLD_PPO = os.path.join(DATA, "ppo_cartpole_7e59869.pth")  # ppo_cartpole.yaml, mlp [8], 4 envs, 2 epochs
OLD_SAC = os.path.join(DATA, "sac_pendulum_7e59869.pth")  # sac_pendulum.yaml, mlp [8], 2 envs, 2 epochs


def test_old_checkpoints_play_without_a_file():
    ppo = ckpt.load(OLD_PPO)
    assert "config_format" not in ppo and "params" in ppo["config"]  # the input dict, as main wrote it
    runner = Runner().load_from_checkpoint(OLD_PPO)
    assert runner.params.network.mlp.units == [8] and runner.params.config.num_actors == 4
    assert runner.play(OLD_PPO, games=1, quiet=True).games == 1
    sac = Runner().load_from_checkpoint(OLD_SAC, ["params.config.player.games_num=1"])
    assert sac.params.algo.name == "sac" and sac.play(OLD_SAC, games=1, quiet=True).games == 1


def test_old_checkpoint_resumes(tmp_path):
    overrides = ["params.network.mlp.units=[8]", "params.config.num_actors=4", "params.config.minibatch_size=32",
                 "params.config.max_epochs=3", f"params.config.train_dir={tmp_path}", "params.config.print_stats=false",
                 "params.config.score_to_win=100000"]
    result = Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml"), overrides).train(checkpoint=OLD_PPO)
    assert result.epoch == 3 and result.frames == 3 * 4 * 16
    state = ckpt.load(os.path.join(result.run_dir, "nn", "last_cartpole.pth"))
    assert state["config_format"] == CONFIG_FORMAT and state["epoch"] == 3


def _write(tmp_path, name, drop=(), **changes):
    state = ckpt.load(OLD_PPO)
    for key in drop:
        state.pop(key)
    state.update(changes)
    path = str(tmp_path / name)
    torch.save(state, path)
    return path


def test_a_checkpoint_without_the_expected_config_is_one_line(tmp_path):
    for path, match in [
        (_write(tmp_path, "none.pth", drop=["config"]),
         r"none.pth: the checkpoint holds no config \(no 'config' with 'params'\); pass the config it was trained "
         r"with: --file"),
        (_write(tmp_path, "future.pth", config={"params": {}}, config_format="rlchain-config-9"),
         r"future.pth: config format 'rlchain-config-9' is not this rlchain's 'rlchain-config-2'"),
    ]:
        with pytest.raises(ckpt.CheckpointError, match=match) as info:
            Runner().load_from_checkpoint(path)
        assert "\n" not in str(info.value)


class Watch(Callback):
    """Records the live e_clip of the trainer and of its agent, after every epoch."""

    def __init__(self):
        self.seen = []

    def on_epoch_end(self, ctx, stats, episodes):
        self.seen.append((ctx.algorithm.cfg.e_clip, ctx.algorithm.agent.cfg.e_clip, ctx.params.config.e_clip))


def test_live_hyperparameters_belong_to_the_run_and_survive_a_resume(tmp_path):
    cfg = copy.deepcopy(BASE)
    cfg["params"]["config"].update(max_epochs=2, train_dir=str(tmp_path), print_stats=False, save_best_after=0,
                                   hyperparam_schedule={1: {"e_clip": 0.1}})
    runner = Runner().load(cfg)
    first = Watch()
    result = runner.train(callbacks=[first])
    assert first.seen == [(0.2, 0.2, 0.2), (0.1, 0.1, 0.2)]  # the parsed config keeps its value
    assert runner.params.config.e_clip == 0.2
    last = os.path.join(result.run_dir, "nn", "last_t.pth")
    state = ckpt.load(last)
    assert state["live_config"] == {"e_clip": 0.1}
    assert state["config"]["params"]["config"]["e_clip"] == 0.2
    assert state["config"]["run"] == {"seed": 1, "device": "cpu", "rank": 0, "world_size": 1, "print_stats": False}

    cfg["params"]["config"].update(max_epochs=3, hyperparam_schedule={})
    resumed = Watch()
    Runner().load(cfg).train(checkpoint=last, callbacks=[resumed])
    assert resumed.seen == [(0.1, 0.1, 0.2)]

    played = Runner().load_from_checkpoint(last)  # the resolved config reads back as the one trained
    assert played.params.config == runner.params.config and played.params.network == runner.params.network


def test_off_policy_live_values_reach_the_agent_and_the_replay_buffer(tmp_path):
    seen = []

    class WatchSac(Callback):
        def on_epoch_end(self, ctx, stats, episodes):
            algo = ctx.algorithm
            seen.append((algo.agent.cfg.critic_tau, algo.buffer.gamma, ctx.params.config.critic_tau))

    overrides = ["params.network.mlp.units=[8]", "params.config.num_actors=2",
                 "params.config.num_steps_per_episode=4", "params.config.num_warmup_frames=8",
                 "params.config.batch_size=8", "params.config.max_epochs=2", "params.config.max_frames=-1",
                 f"params.config.train_dir={tmp_path}", "params.config.print_stats=false",
                 "params.config.hyperparam_schedule={1: {critic_tau: 0.5, gamma: 0.9}}"]
    Runner().load(os.path.join(CONFIGS, "sac_pendulum.yaml"), overrides).train(callbacks=[WatchSac()])
    assert seen == [(0.005, 0.99, 0.005), (0.5, 0.9, 0.005)]
