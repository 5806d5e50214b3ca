"""algo distill on Dict observations kept per key (TorchCameraReach-v0): a camera student (multi_input on the
image and the proprioception, the goal left out) from a state teacher, a couple of epochs each. The flat
teacher (ppo_camera_reach_state.yaml) reads the keys obs_groups.teacher names, concatenated; a multi_input
teacher reads its own keys per key. The student's observations are stored per key (the image as uint8), it
plays and exports alone (no goal input), resumes, and wrong teacher / student key combinations are one-line errors
naming the key."""

import glob
import os

import pytest
import torch

from rlchain import Runner
from rlchain.algos.distill.distill import Distill
from rlchain.config.errors import ConfigError
from rlchain.inference.export.onnx import export_from_cli, onnx_session
from rlchain.inference.player import Player
from rlchain.runs import checkpoint as ckpt
from tests.conftest import CONFIGS
from tests.smoke.test_train_play_resume import small

pytestmark = pytest.mark.smoke
STATE = os.path.join(CONFIGS, "ppo_camera_reach_state.yaml")
DISTILL = os.path.join(CONFIGS, "distill_camera_reach.yaml")
TINY = ["params.config.num_actors=4", "params.config.horizon_length=16", "params.config.full_experiment_name=null"]
PER_KEY_TEACHER = ["params.config.name=mi_teacher", "params.config.env_config={device: cpu, privileged: True}",
                   "params.network={name: multi_input, inputs: {image: {encoder: none}}, "
                   "space: {continuous: {fixed_sigma: True}}, mlp: {units: [32]}}"]
NO_GOAL = ["params.config.env_config={device: cpu}",  # the student's network names no goal key either
           "params.network.inputs={image: {encoder: cnn, units: [32]}, proprio: {encoder: mlp, units: [16]}}"]


@pytest.fixture(scope="module")
def teachers(tmp_path_factory):
    """Two teachers after one tiny PPO epoch: an MLP on the state vector, a multi_input one on the Dict's keys."""
    tmp = tmp_path_factory.mktemp("teachers")
    for extra in ([], PER_KEY_TEACHER):
        Runner().load(STATE, [*TINY, "params.config.minibatch_size=64", *small(tmp, 1, extra)]).train()
    return (glob.glob(str(tmp / "runs" / "*" / "nn" / "last_camera_reach_state.pth"))[0],
            glob.glob(str(tmp / "runs" / "*" / "nn" / "last_mi_teacher.pth"))[0])


def distill(tmp_path, teacher, epochs=1, extra=()):
    return Runner().load(DISTILL, [*TINY, "params.config.minibatches=2", "params.network.mlp.units=[32]",
                                   f"params.config.teacher_checkpoint={teacher}", *small(tmp_path, epochs, extra)])


def test_a_camera_student_from_a_state_teacher_stores_per_key_plays_and_exports_alone(teachers, tmp_path, monkeypatch,
                                                                                    capsys):
    seen = {}
    real = Distill.update

    def update(self):  # the rollout the student is fitted on, as stored
        seen["obs"] = self.batch["obs"]
        return real(self)

    monkeypatch.setattr(Distill, "update", update)
    groups = "params.config.obs_groups={teacher: [proprio, goal], student_noise_std: 0.05, student_delay: 1}"
    runner = distill(tmp_path, teachers[0], 2, [groups])
    result = runner.train()
    assert result.epoch == 2 and result.frames == 2 * 4 * 16
    assert seen["obs"]["image"].dtype == torch.uint8 and seen["obs"]["image"].shape == (16, 4, 1, 24, 24)
    last = glob.glob(str(tmp_path / "runs" / "*" / "nn" / "last_distill_camera_reach.pth"))[0]
    state = ckpt.load(last)
    assert any(".encoders.image." in k for k in state["model"]) and not any(".encoders.goal." in k
                                                                             for k in state["model"])
    # the state teacher: proprio then goal
    assert state["teacher"]["model"]["running_mean_std.running_mean"].shape == (6,)
    player = Player(runner.params, last)
    try:
        assert player.play(games=1, quiet=True).games == 1  # the student alone, without the teacher
    finally:
        player.close()
    out = str(tmp_path / "student.onnx")  # parity on env observations that carry the goal too
    export_from_cli(runner, last, out, num_random=4, num_envs=2, env_steps=2)
    assert float(capsys.readouterr().out.split("max abs diff ")[1].split(" ")[0]) < 1e-4
    assert [i.name for i in onnx_session(out).get_inputs()] == ["image", "proprio"]  # no goal input
    resumed = distill(tmp_path, teachers[0], 3, [groups]).train(checkpoint=last)  # the saved Dict, per key again
    assert resumed.epoch == 3 and resumed.frames == 3 * 4 * 16


def test_a_multi_input_teacher_reads_its_own_keys(teachers, tmp_path):
    assert distill(tmp_path, teachers[1], 1, ["params.config.obs_groups=null"]).train().epoch == 1


@pytest.mark.parametrize("teacher, extra, match", [
    (0, ["params.config.obs_groups=null"],  # a flat teacher given every key, the image too
     r"params\.config\.teacher_checkpoint: the teacher does not load on the keys goal, image, proprio concatenated "
     r"\(582 features\).*name the keys it reads in params\.config\.obs_groups\.teacher"),
    (0, NO_GOAL, r"params\.config\.obs_groups\.teacher\[1\]: 'goal' is not a key of the observations; keys: image"),
    (1, ["params.config.obs_groups=null", *NO_GOAL],
     r"params\.config\.teacher_checkpoint: the teacher in .* reads goal .* observations \(image, proprio\) lack"),
    (1, ["params.config.obs_groups={teacher: [proprio]}"], r"params\.config\.obs_groups\.teacher: leaves out goal"),
    (0, ["params.config.obs_groups={teacher: [proprio, goal], student: [image]}"],
     r"params\.config\.obs_groups\.student: the observations are a Dict kept per key .*encoder: none"),
])
def test_wrong_teacher_and_student_keys_are_one_line_errors(teachers, tmp_path, teacher, extra, match):
    with pytest.raises(ConfigError, match=match) as info:
        distill(tmp_path, teachers[teacher], 1, extra).train()
    assert "distill_camera_reach.yaml" in str(info.value) and "\n" not in str(info.value)
