"""Every env a training run opens is closed, however the run ends: a finished run, an
env that raises, a divergence, a failing callback, Ctrl-C, a trainer that fails to start."""

import os

import pytest

import rlchain.algos.base.algorithm as algorithm_base
import rlchain.algos.ppo.ppo as ppo_trainer
import tests.smoke.broken_envs  # noqa: F401  (registers the broken envs)
from rlchain import Runner
from rlchain.config import ConfigError
from rlchain.errors import DivergenceError, EnvError
from rlchain.training import loop
from rlchain.training.events import Callback
from tests.conftest import CONFIGS
from tests.smoke.test_train_play_resume import small

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
EVALUATION = ["params.config.evaluation.interval=1", "params.config.evaluation.games=2",
              "params.config.evaluation.num_envs=2", "params.config.print_stats=false",
              "params.config.num_actors=4", "params.config.minibatch_size=64"]


@pytest.fixture
def opened(monkeypatch):
    """Every env the run builds (training env: the Runner's build_env, evaluation env: the loop's),
    as [kind, env, closed?]."""
    envs = []

    def recording(kind, original):
        def build_env(*args, **kwargs):
            env = original(*args, **kwargs)
            entry = [kind, env, False]
            envs.append(entry)
            close = env.close

            def closing():
                entry[2] = True
                close()

            env.close = closing
            return env
        return build_env

    # the training env: built by the algorithm class (build_training_env: PPO's, or AlgorithmBase's default)
    for module in (ppo_trainer, algorithm_base):
        monkeypatch.setattr(module, "build_env", recording("train", module.build_env))
    monkeypatch.setattr(loop, "build_env", recording("evaluation", loop.build_env))
    return envs


class RaiseAt(Callback):
    """Raises ``error`` at the end of epoch ``epoch``."""

    def __init__(self, error, epoch=1):
        self.error, self.epoch = error, epoch

    def on_epoch_end(self, ctx, stats, episodes):
        if ctx.state.epoch == self.epoch:
            raise self.error


def assert_all_closed(envs):
    assert sorted(kind for kind, _, _ in envs) == ["evaluation", "train"]
    assert [kind for kind, _, closed in envs if not closed] == []


def test_finished_run_closes_its_envs(tmp_path, opened):
    Runner().load(CARTPOLE, small(tmp_path, epochs=1, extra=EVALUATION)).train()
    assert_all_closed(opened)


@pytest.mark.parametrize("overrides,callbacks,error", [
    (["params.config.env_name=RaisingCartPole-test"], [], EnvError),  # the env raises at its step 7
    (["params.config.env_name=NanRewardCartPole-test"], [], DivergenceError),
    ([], [RaiseAt(RuntimeError("callback bug"))], RuntimeError),
    ([], [RaiseAt(KeyboardInterrupt())], KeyboardInterrupt),  # a second Ctrl-C, or one outside the loop
    (["params.config.use_action_masks=true"], [], ConfigError),  # the trainer fails after building its eval env
], ids=["env-error", "divergence", "callback-error", "keyboard-interrupt", "trainer-init-error"])
def test_failed_run_closes_its_envs(tmp_path, opened, overrides, callbacks, error):
    runner = Runner().load(CARTPOLE, small(tmp_path, epochs=3, extra=[*EVALUATION, *overrides]))
    with pytest.raises(error):
        runner.train(callbacks=callbacks)
    assert_all_closed(opened)


def test_a_failing_close_does_not_hide_the_others_or_the_error(tmp_path, opened, capsys):
    class BadClose(Callback):
        def close(self):
            raise OSError("disk gone")

    runner = Runner().load(CARTPOLE, small(tmp_path, epochs=3, extra=EVALUATION))
    with pytest.raises(RuntimeError, match="callback bug"):
        runner.train(callbacks=[BadClose(), RaiseAt(RuntimeError("callback bug"))])
    assert_all_closed(opened)
    assert "closing callback BadClose failed: OSError: disk gone" in capsys.readouterr().out
