"""algo distill (rlchain/algos/distill/) on CartPole, a couple of epochs each: the shipped teacher
(nn/cartpole.pth, PPO on the full state) labels, an LSTM student on positions only learns; the checkpoint
holds both and resumes; --play and the ONNX export take the student alone; stage three (PPO from the
distilled student, config.distilled_checkpoint) starts from its weights; bad teachers, views and students
are one-line errors naming the key."""

import glob
import os

import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.config.packaged import resolve_checkpoint
from rlchain.inference.export.onnx import export_onnx, onnx_session
from rlchain.inference.player import Player
from rlchain.runs import checkpoint as ckpt
from tests.conftest import CONFIGS
from tests.smoke.test_train_play_resume import small

pytestmark = pytest.mark.smoke
DISTILL = os.path.join(CONFIGS, "distill_cartpole_lstm.yaml")
FINETUNE = os.path.join(CONFIGS, "ppo_cartpole_student_finetune.yaml")
TEACHER = resolve_checkpoint("cartpole")[0]  # the packaged checkpoint (nn/cartpole.pth in a clone)
FAST = ["params.config.num_actors=4", "params.config.horizon_length=16", "params.config.teacher_action_prob_epochs=1",
        f"params.config.teacher_checkpoint={TEACHER}", "params.config.full_experiment_name=null"]


def distill(tmp_path, epochs=2, extra=()):
    return Runner().load(DISTILL, [*FAST, *small(tmp_path, epochs, extra)])


@pytest.fixture(scope="module")
def distilled(tmp_path_factory):
    """A student after 3 epochs (the checkpoint and the run's tags)."""
    tmp_path = tmp_path_factory.mktemp("distill")
    result = distill(tmp_path, 3).train()
    last = glob.glob(str(tmp_path / "runs" / "*" / "nn" / "last_distill_cartpole_lstm.pth"))[0]
    return result, last, tmp_path


def test_distill_trains_checkpoints_both_and_resumes(distilled, tmp_path):
    result, last, _ = distilled
    assert result.epoch == 3 and result.frames == 3 * 4 * 16
    state = ckpt.load(last)
    assert state["algo"] == "distill" and "optimizer" in state["agent"]
    assert set(state["teacher"]) == {"model", "path", "config"}
    teacher_keys = set(ckpt.load(TEACHER)["model"])
    assert set(state["teacher"]["model"]) == teacher_keys  # the teacher's weights, as trained
    assert state["model"]["running_mean_std.running_mean"].shape == (2,)  # the student saw 2 features
    resumed = distill(tmp_path, 5).train(checkpoint=last)
    assert resumed.epoch == 5 and resumed.frames == 5 * 64


def test_distill_logs_behavior_loss_and_both_returns(tmp_path, monkeypatch):
    from rlchain.runs.logging import TrainLogger
    tags = {}
    real = TrainLogger.emit

    def emit(self, scalars, step):
        for tag, value in scalars.items():
            tags.setdefault(tag, []).append(value)
        real(self, scalars, step)

    monkeypatch.setattr(TrainLogger, "emit", emit)
    distill(tmp_path, 2, ["params.config.horizon_length=128", "params.config.teacher_action_prob=0.5",
                          "params.config.teacher_action_prob_end=0.5",
                          "params.config.env_config={max_episode_steps: 100}",  # and a corrupted, late sensor:
                          "params.config.obs_groups={student: [0, 2], student_noise_std: 0.05, student_dropout: 0.1, "
                          "student_delay: 2}"]).train()
    assert len(tags["losses/behavior"]) == 2 and all(np.isfinite(tags["losses/behavior"]))
    assert tags["info/teacher_action_prob"] == [0.5, 0.5]
    assert "rewards/teacher" in tags and "rewards/student" in tags  # episodes played wholly by each
    assert min(tags["rewards/teacher"]) == 100  # the shipped teacher balances the pole to the time limit


def test_play_and_onnx_take_the_student_alone(distilled, tmp_path):
    _, last, _ = distilled
    params = distill(tmp_path).params
    player = Player(params, last)
    try:
        assert player.model.obs_slice == (0, 2) and player.model.obs_group == "student"
        result = player.play(games=2, quiet=True)
        assert result.games == 2 and result.mean_length > 0
    finally:
        player.close()
    out = export_onnx(params, last, str(tmp_path / "student.onnx"))
    session = onnx_session(out)
    inputs = {i.name: i.shape for i in session.get_inputs()}
    assert inputs["obs"][1] == 2 and {"rnn_state_0", "rnn_state_1"} <= set(inputs)  # 2 features, LSTM states
    model = Player(params, last).model
    rng = np.random.default_rng(0)
    full = rng.normal(size=(5, 4)).astype(np.float32)
    h = np.zeros((1, 5, 64), np.float32)
    feed = {"obs": full[:, [0, 2]], "rnn_state_0": h, "rnn_state_1": h}
    action, _, *_ = session.run(None, feed)
    with torch.no_grad():
        params_t, _, _ = model.evaluate(torch.from_numpy(full))
    np.testing.assert_array_equal(action, model.dist.mode(params_t).numpy())  # onnxruntime == PyTorch
    changed = full.copy()
    changed[:, [1, 3]] = rng.normal(size=(5, 2))  # the velocities the student never sees
    with torch.no_grad():
        assert torch.equal(model.evaluate(torch.from_numpy(changed))[0], params_t)


def test_cli_export_checks_parity_on_the_view(distilled, tmp_path, capsys):
    from rlchain.inference.export.onnx import export_from_cli
    _, last, _ = distilled
    runner = distill(tmp_path)
    export_from_cli(runner, last, str(tmp_path / "s.onnx"), num_random=8, num_envs=2, env_steps=4)
    out = capsys.readouterr().out
    assert "(input: obs_groups.student, 2 features)" in out
    diffs = [float(x) for x in out.split("max abs diff ")[1].split(" on ")[0:1]]
    assert diffs[0] < 1e-4


@pytest.mark.parametrize("value", ["scratch", "teacher"])
def test_stage_three_ppo_starts_from_the_distilled_student(distilled, tmp_path, monkeypatch, value):
    from rlchain.algos.ppo import ppo as ppo_module
    from rlchain.training.events import Callback
    _, last, _ = distilled
    runner = Runner().load(FINETUNE, [f"params.config.distilled_checkpoint={last}",
                                      f"params.config.distilled_value={value}",
                                      "params.config.distilled_value_epochs=1", "params.config.num_actors=8",
                                      "params.config.minibatch_size=128", *small(tmp_path, 1)])
    seen = {}
    real = ppo_module.warm_start_value

    def warm_start(trainer, teacher, epochs):  # records the model right after the value head's regression
        mse = real(trainer, teacher, epochs)
        seen["warm"] = {k: v.clone() for k, v in trainer.model.state_dict().items()}
        return mse

    monkeypatch.setattr(ppo_module, "warm_start_value", warm_start)

    class Start(Callback):
        def on_train_start(self, ctx):
            seen["start"] = {k: v.clone() for k, v in ctx.algorithm.model.state_dict().items()}

    runner.train(callbacks=[Start()])
    student = ckpt.load(last)["model"]
    assert all(torch.equal(seen["start"][k], v) for k, v in student.items())  # PPO starts as the student
    assert ("warm" in seen) == (value == "teacher")
    if value == "teacher":  # the value layer moved, nothing else did: the policy is the distilled one
        moved = {k for k, v in student.items() if not torch.equal(seen["warm"][k], v)}
        assert moved and all(k.startswith("a2c_network.value") for k in moved), moved


def test_a_teacher_with_another_action_space_is_a_one_line_error(tmp_path):
    pendulum = resolve_checkpoint("pendulum")[0]
    with pytest.raises(ConfigError, match=r"params\.config\.teacher_checkpoint: .*action space") as info:
        distill(tmp_path, 1, [f"params.config.teacher_checkpoint={pendulum}"]).train()
    assert "\n" not in str(info.value)


def test_a_teacher_view_other_than_its_training_is_a_one_line_error(tmp_path):
    with pytest.raises(ConfigError, match=r"params\.config\.obs_groups\.teacher: gives 2 features .* trained on 4"):
        distill(tmp_path, 1, ["params.config.obs_groups.teacher=[0, 2]"]).train()


def test_a_missing_teacher_or_bad_group_name_is_a_one_line_error(tmp_path):
    with pytest.raises(ConfigError, match=r"params\.config\.teacher_checkpoint: .*checkpoint not found"):
        distill(tmp_path, 1, [f"params.config.teacher_checkpoint={tmp_path}/none.pth"]).train()
    with pytest.raises(ConfigError, match=r"params\.config\.obs_groups\.studen: unknown key; did you mean 'student'"):
        distill(tmp_path, 1, ["params.config.obs_groups.studen=[0]"])
    with pytest.raises(ConfigError, match=r"params\.config\.obs_groups\.student\[0\]: index 7 is out of range"):
        distill(tmp_path, 1, ["params.config.obs_groups.student=[7]"]).train()


def test_a_student_network_that_cannot_take_its_view_is_a_one_line_error(tmp_path):
    cnn = ["params.network.cnn={type: conv2d, convs: [{filters: 4, kernel_size: 3, strides: 1, padding: 0}]}"]
    with pytest.raises(ConfigError, match=r"params\.config\.obs_groups\.student: the network cannot take this view"):
        distill(tmp_path, 1, cnn).train()


def test_the_central_value_reads_obs_groups_critic_on_a_plain_env(tmp_path):
    cv = "{network: {name: actor_critic, central_value: True, mlp: {units: [32]}}, learning_rate: 1e-3, mini_epochs: 2}"
    runner = Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml"), [
        f"params.config.central_value_config={cv}", "params.config.num_actors=16",
        "params.config.obs_groups={student: [0, 2], critic: ['0:4'], policy: student}", *small(tmp_path, 1)])
    runner.train()
    last = glob.glob(str(tmp_path / "runs" / "*" / "nn" / "last_cartpole.pth"))[0]
    state = ckpt.load(last)
    assert state["model"]["a2c_network.actor_mlp.0.weight"].shape[1] == 2  # the actor: positions
    first = [v for k, v in state["central_value"].items() if k.endswith("weight")][0]
    assert first.shape[1] == 4  # the critic: the full state, no {'obs', 'state'} env needed
