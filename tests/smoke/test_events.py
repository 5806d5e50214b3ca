"""Events, config-named callbacks, rl_games AlgoObserver adapter and in-training evaluation."""

import os

import pytest

from rlchain import Runner
from rlchain.config import ConfigError
from rlchain.training.events import Callback
from tests.conftest import CONFIGS
from tests.smoke.test_train_play_resume import small

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
SEEN = []


class Recorder(Callback):
    """Records every event it gets (named from YAML in a test below)."""

    def on_train_start(self, trainer):
        SEEN.append(("start", trainer.epoch))

    def on_epoch_end(self, trainer, stats, episodes):
        SEEN.append(("epoch", trainer.epoch, "kl" in stats))

    def on_evaluation(self, trainer, result):
        SEEN.append(("evaluation", trainer.epoch, result.games))

    def on_checkpoint(self, trainer, path, kind):
        SEEN.append(("checkpoint", kind, os.path.isfile(path)))

    def on_train_end(self, trainer, result):
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


def test_algo_observer_and_function_callbacks(tmp_path):
    observer, epochs = Observer(), []
    Runner().load(CARTPOLE, small(tmp_path, epochs=2, extra=["params.config.print_stats=false"])).train(
        callbacks=[observer, lambda trainer, stats, episodes: epochs.append(trainer.epoch)])
    assert observer.calls[:2] == ["before_init", "after_init"]
    assert observer.calls[2:] == [("after_print_stats", 512, 1), ("after_print_stats", 1024, 2)]
    assert epochs == [1, 2]


def test_bad_callback_name_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match=r"params.config.callbacks\[0\]: module 'tests.smoke.test_events' has no"):
        Runner().load(CARTPOLE, ["params.config.callbacks=['tests.smoke.test_events:Nope']"])
    with pytest.raises(ConfigError, match=r"must look like"):
        Runner().load(CARTPOLE, ["params.config.callbacks=['justaname']"])


def test_get_set_params_during_training(tmp_path, capsys):
    seen = []

    def tweak(trainer, stats, episodes):
        if trainer.epoch == 1:
            assert trainer.get_params()["entropy_coef"] == 0.0
            trainer.set_params(learning_rate=1e-4, entropy_coef=0.01, mini_epochs=2)
        seen.append((trainer.epoch, trainer.get_params()["learning_rate"], trainer.get_params()["entropy_coef"]))

    Runner().load(CARTPOLE, small(tmp_path, epochs=3, extra=["params.config.print_stats=false",
                                                             "params.config.lr_schedule=None"])).train(
        callbacks=[tweak])
    assert seen[1:] == [(2, pytest.approx(1e-4), 0.01), (3, pytest.approx(1e-4), 0.01)]
    assert "set entropy_coef = 0.01 at epoch 1" in capsys.readouterr().out
    with pytest.raises(KeyError, match="cannot set gamma_typo"):
        from rlchain.training.on_policy import OnPolicyTrainer
        OnPolicyTrainer.set_params(type("T", (), {"TUNABLE": OnPolicyTrainer.TUNABLE})(), gamma_typo=1)
