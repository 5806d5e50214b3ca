"""algo distill with a SAC teacher (the shipped rlchain/checkpoints/pendulum_sac.pth, a SAC Pendulum
policy) labels with its deterministic action and a Gaussian student fits it. Bad pairings are one-line errors.
(``multi_gpu: True`` for distill under a 2-rank torchrun: test_distributed.py's ``distill`` scenario.)"""

import glob
import os

import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from tests.conftest import CONFIGS, ROOT
from tests.smoke.test_distill import DISTILL, FAST
from tests.smoke.test_train_play_resume import small

pytestmark = pytest.mark.smoke
SAC_DISTILL = os.path.join(CONFIGS, "distill_pendulum_sac.yaml")
SAC_TEACHER = os.path.join(ROOT, "rlchain", "checkpoints", "pendulum_sac.pth")
SAC_FAST = [f"params.config.teacher_checkpoint={SAC_TEACHER}", "params.config.num_actors=4",
            "params.config.horizon_length=32", "params.config.full_experiment_name=null"]


def sac_distill(tmp_path, epochs=2, extra=()):
    return Runner().load(SAC_DISTILL, [*SAC_FAST, *small(tmp_path, epochs, extra)])


def test_sac_teacher_labels_are_its_deterministic_env_action(tmp_path):
    from rlchain.training.events import Callback
    runner = sac_distill(tmp_path)
    losses = []

    class Record(Callback):
        def on_epoch_end(self, ctx, stats, episodes):
            losses.append(stats["behavior_loss"])

    result = runner.train(callbacks=[Record()])
    assert result.epoch == 2 and len(losses) == 2
    assert losses[1] < losses[0], losses  # the student moves towards the teacher's actions
    last = glob.glob(str(tmp_path / "runs" / "*" / "nn" / "last_*.pth"))[0]
    state = torch.load(last, weights_only=False)
    assert any(k.startswith("network.actor.trunk.") for k in state["teacher"]["model"])  # the SAC weights, its keys
    # stage three from this student: PPO starts from it (scratch value head); a teacher value warm start
    # needs a PPO teacher's state values, which SAC has not
    stage3 = ["params.config.max_epochs=1", f"params.config.train_dir={tmp_path}/ppo", "params.config.num_actors=4",
              "params.config.horizon_length=32", "params.config.minibatch_size=64",
              "params.config.normalize_value=False", f"params.config.distilled_checkpoint={last}"]
    ppo = os.path.join(CONFIGS, "ppo_pendulum.yaml")
    assert Runner().load(ppo, [*stage3, "params.config.distilled_value=scratch"]).train().epoch == 1
    with pytest.raises(ConfigError, match=r"distilled_value: teacher regresses on a PPO teacher's state values"):
        Runner().load(ppo, [*stage3, "params.config.distilled_value=teacher"]).train()


def test_sac_teacher_label_maps_onto_sacs_env_action():
    from rlchain.algos.distill.teacher import SACTeacher, load_teacher
    from rlchain.models.build import build_env, build_model
    from rlchain.runs import checkpoint as ckpt
    runner = Runner().load(SAC_DISTILL, SAC_FAST)
    env = build_env(runner.params, 2, 0)
    try:
        student = build_model(runner.params, env, torch.device("cpu"))
        teacher = load_teacher(runner.params, env, torch.device("cpu")).model
        assert isinstance(teacher, SACTeacher)
        teacher.bind(student.dist)
        obs = torch.randn(5, 3)
        labels, _, _ = teacher.evaluate(obs)
        sac = teacher.sac
        expected = sac.dist.to_env(sac.act(obs, deterministic=True)["actions"])  # as SAC acts in the env
        assert torch.allclose(student.dist.to_env(student.dist.mode(labels)), expected, atol=1e-5)
        assert ckpt.load(SAC_TEACHER)["algo"] == "sac"
    finally:
        env.close()


def test_sac_teacher_bad_pairings_are_one_line_errors(tmp_path):
    with pytest.raises(ConfigError, match=r"params\.config\.loss: kl needs the teacher's action distribution"):
        sac_distill(tmp_path, extra=["params.config.loss=kl"]).train()
    # a SAC (Box) teacher on CartPole (discrete actions)
    with pytest.raises(ConfigError, match=r"teacher_checkpoint: the SAC teacher in .*\(Box\) action space; "
                                          r"this env's is Discrete"):
        Runner().load(DISTILL, [*FAST, *small(tmp_path, 1), f"params.config.teacher_checkpoint={SAC_TEACHER}",
                                "params.config.obs_groups.student=null"]).train()


def test_sac_teacher_with_another_action_size_is_a_one_line_error():
    from types import SimpleNamespace

    from rlchain.algos.distill.distill import _check_sac_student
    teacher = SimpleNamespace(dist=SimpleNamespace(dim=1))
    with pytest.raises(ConfigError, match=r"teacher_checkpoint: the SAC teacher acts with 1 continuous actions, "
                                          r"the student has 6 continuous ones"):
        _check_sac_student("x.yaml", SimpleNamespace(continuous=True, dim=6), teacher)
    _check_sac_student("x.yaml", SimpleNamespace(continuous=True, dim=1), teacher)  # the same size: fine
    discrete = SimpleNamespace(dist=SimpleNamespace(param_size=2))  # a SAC teacher of Discrete actions
    with pytest.raises(ConfigError, match=r"teacher_checkpoint: the SAC teacher acts with Discrete actions: a SAC "
                                          r"teacher labels continuous actions only") as err:
        _check_sac_student("x.yaml", SimpleNamespace(continuous=False, param_size=2), discrete)
    assert "\n" not in str(err.value)
