"""The Algorithm protocol: a user's algorithm is one module, one config class and one registration.

``tests/smoke/user_algo/reinforce.py`` is such an algorithm (REINFORCE); here it trains through the
Runner from a YAML, as a shipped algorithm would, and gets every Loop feature without code of its
own: metric logging under its tags, the console line, checkpoints and resume, get/set params, its
config keys checked, and a clear multi_gpu refusal. SAC and DQN's get/set params are tested too.
"""

import glob
import os

import pytest

from rlchain import Runner
from rlchain.algos.base.algorithm import Algorithm
from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt
from rlchain.runs.logging import TrainLogger
from rlchain.training.events import Callback
from rlchain.training.loop import Loop
from tests.conftest import CONFIGS
from tests.smoke.test_train_play_resume import small

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
REINFORCE = ["params.import_modules=[tests.smoke.user_algo]", "params.algo.name=reinforce",
             "params.config.num_actors=4", "params.config.horizon_length=32"]


def reinforce(tmp_path, epochs=2, extra=()):
    return Runner().load(CARTPOLE, [*REINFORCE, *small(tmp_path, epochs, extra)])


def test_a_user_algorithm_trains_logs_and_resumes_through_the_loop(tmp_path, monkeypatch, capsys):
    tags = {}
    real = TrainLogger.emit  # every scalar goes to the log writers through it

    def emit(self, scalars, step):
        for tag, value in scalars.items():
            tags.setdefault(tag, []).append(value)
        real(self, scalars, step)

    monkeypatch.setattr(TrainLogger, "emit", emit)
    seen, loops = [], []

    class IsAlgorithm(Callback):
        def on_train_start(self, ctx):
            loops.append(isinstance(ctx.algorithm, Algorithm) and not isinstance(ctx.algorithm, Loop))

    result = reinforce(tmp_path, epochs=3).train(callbacks=[IsAlgorithm(), lambda ctx, stats, episodes: seen.append(
        (ctx.state.algo, ctx.state.epoch, ctx.state.frames, sorted(stats), dict(ctx.state.stats) == stats))])
    assert result.epoch == 3 and result.frames == 3 * 4 * 32
    assert loops == [True] and seen[0] == ("reinforce", 1, 128, ["lr", "mean_return", "pg_loss"], True)
    assert len(tags["losses/pg_loss"]) == 3 and len(tags["info/mean_return"]) == 3  # its own tags
    assert len(tags["performance/step_fps"]) == 3 and "rewards/step" in tags  # the Loop's
    out = capsys.readouterr().out
    assert "epoch 3/3 | frames 384 |" in out and "| pg_loss " in out
    last = glob.glob(str(tmp_path / "runs" / "*" / "nn" / "last_cartpole.pth"))[0]
    state = ckpt.load(last)
    assert state["algo"] == "reinforce" and state["epoch"] == 3 and "optimizer" in state["agent"]
    resumed = reinforce(tmp_path, epochs=5).train(checkpoint=last)
    assert resumed.epoch == 5 and resumed.frames == 5 * 128


def test_a_user_algorithm_gets_set_params_from_the_loop(tmp_path):
    seen = []

    def tweak(ctx, stats, episodes):
        if ctx.state.epoch == 1:
            ctx.set_params(learning_rate=1e-4, gamma=0.9)
        seen.append((ctx.get_params()["learning_rate"], ctx.get_params()["gamma"]))

    reinforce(tmp_path, epochs=2).train(callbacks=[tweak])
    assert seen == [(pytest.approx(1e-3), pytest.approx(0.99)), (pytest.approx(1e-4), pytest.approx(0.9))]
    with pytest.raises(KeyError, match="cannot set e_clip; settable: learning_rate, gamma"):
        reinforce(tmp_path, epochs=1).train(callbacks=[lambda t, s, e: t.set_params(e_clip=0.1)])


def test_a_user_algorithm_config_class_checks_its_keys(tmp_path):
    assert reinforce(tmp_path, extra=["params.config.baseline=False"]).params.config.baseline is False
    with pytest.raises(ConfigError, match=r"params\.config\.baselin.*did you mean 'baseline'"):
        reinforce(tmp_path, extra=["params.config.baselin=False"])


def test_multi_gpu_for_an_algorithm_without_it_is_a_one_line_error(tmp_path, monkeypatch):
    for name, value in (("RANK", "0"), ("WORLD_SIZE", "2"), ("LOCAL_RANK", "0"), ("MASTER_ADDR", "127.0.0.1"),
                        ("MASTER_PORT", "29999")):
        monkeypatch.setenv(name, value)
    with pytest.raises(ConfigError, match=r"params\.config\.multi_gpu: 'reinforce' does not support multi_gpu"):
        reinforce(tmp_path, extra=["params.config.multi_gpu=True"]).train()


@pytest.mark.parametrize("config,changes,check", [
    ("sac_pendulum.yaml", {"actor_lr": 1e-5, "critic_tau": 0.01},
     lambda t: (t.algorithm.agent.actor_opt.param_groups[0]["lr"], t.algorithm.cfg.critic_tau) == (1e-5, 0.01)),
    ("dqn_cartpole.yaml", {"learning_rate": 2e-5, "gamma": 0.9},
     lambda t: (t.algorithm.agent.opt.param_groups[0]["lr"], t.algorithm.cfg.gamma,
                t.algorithm.buffer.gamma) == (2e-5, 0.9, 0.9)),
])
def test_sac_and_dqn_get_and_set_params(tmp_path, config, changes, check):
    seen = []

    class Tweak(Callback):
        def on_epoch_end(self, ctx, stats, episodes):
            if ctx.state.epoch == 1:
                assert set(changes) <= set(ctx.get_params())
                ctx.set_params(**changes)
            else:
                seen.append((check(ctx), {k: ctx.get_params()[k] for k in changes}))

    Runner().load(os.path.join(CONFIGS, config), small(tmp_path, 2, ["params.config.num_warmup_frames=0"])).train(
        callbacks=[Tweak()])
    assert seen == [(True, changes)]
