"""Observation groups (rlchain/envs/obs_groups.py, config/obs_groups.py) and the distillation's pure parts:
the behaviour losses (algos/core/behavior.py) and the student's sensor corruption."""

import os

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.algos.core.behavior import behavior_loss, resolve_loss
from rlchain.algos.distill.distill import corrupt
from rlchain.config.errors import ConfigError
from rlchain.config.fields import parse_dataclass
from rlchain.config.obs_groups import ObsGroupsConfig
from rlchain.envs.obs_groups import group_parts, resolve_view
from rlchain.envs.wrappers.central_value import ObsStateBox
from rlchain.envs.wrappers.dict_obs import FlatDictBox
from rlchain.models.distributions import Categorical, DiagGaussian

BOX = gym.spaces.Box(-1, 1, (6,), np.float32)
DICT = FlatDictBox(gym.spaces.Dict({"joint_pos": gym.spaces.Box(-1, 1, (3,)), "joint_vel": gym.spaces.Box(-1, 1, (3,)),
                                    "imu": gym.spaces.Box(-1, 1, (2,))}), np.float32)


def test_indices_and_slices_of_a_flat_observation():
    view = resolve_view(BOX, [0, 2, "4:"], "student", "params.config.obs_groups.student")
    assert view.indices == (0, 2, 4, 5) and view.size == 4 and not view.whole
    assert view.selector() == (0, 2, 4, 5)
    assert resolve_view(BOX, ["1:3"], "s", "k").selector() == slice(1, 3)
    assert resolve_view(BOX, [-1], "s", "k").indices == (5,)
    assert resolve_view(BOX, None, "teacher", "k").whole
    np.testing.assert_array_equal(view.take(np.arange(12).reshape(2, 6)), [[0, 2, 4, 5], [6, 8, 10, 11]])


def test_dict_keys_in_the_flat_layout_and_a_dict_view_for_the_network():
    # gymnasium sorts a Dict's keys: imu (0:2), joint_pos (2:5), joint_vel (5:8)
    view = resolve_view(DICT, ["joint_pos", "imu"], "student", "k")
    assert view.indices == (0, 1, 2, 3, 4)  # in the view's Dict order (imu, joint_pos)
    assert isinstance(view.space, gym.spaces.Dict) and list(view.space.spaces) == ["imu", "joint_pos"]
    assert resolve_view(DICT, ["joint_vel"], "s", "k").indices == (5, 6, 7)


def test_central_value_obs_and_state_are_named_parts():
    space = ObsStateBox(3, 5)
    assert resolve_view(space, group_parts(None, "teacher", space), "teacher", "k").selector() == slice(0, 3)
    assert resolve_view(space, group_parts(None, "critic", space), "critic", "k").selector() == slice(3, 8)
    groups = ObsGroupsConfig(critic=["obs", "state"])
    assert resolve_view(space, group_parts(groups, "critic", space), "critic", "k").whole


@pytest.mark.parametrize("parts,message", [
    (["joint_poss"], r"obs_groups\.student\[0\]: 'joint_poss' is not a part of the observation; did you mean "
                     r"'joint_pos'"),
    ([9], r"obs_groups\.student\[0\]: index 9 is out of range for an observation of size 8"),
    (["a:b"], r"obs_groups\.student\[0\]: 'a:b' is not a 'start:stop' slice"),
    (["6:2"], r"obs_groups\.student\[0\]: slice '6:2' selects nothing"),
    (["imu", 1], r"obs_groups\.student\[1\]: 1 repeats observation index 1"),
])
def test_bad_parts_are_one_line_errors_naming_the_key(parts, message):
    with pytest.raises(ConfigError, match=message) as info:
        resolve_view(DICT, parts, "student", "params.config.obs_groups.student", "cfg.yaml")
    assert "\n" not in str(info.value) and str(info.value).startswith("cfg.yaml: ")


def test_a_key_on_a_flat_observation_says_it_has_no_names():
    with pytest.raises(ConfigError, match="no named parts|named parts: none"):
        resolve_view(BOX, ["pos"], "student", "params.config.obs_groups.student")


def test_a_bad_group_name_or_form_is_a_config_error():
    with pytest.raises(ConfigError, match=r"params\.config\.obs_groups\.studnet: unknown key; did you mean 'student'"):
        parse_dataclass(ObsGroupsConfig, {"studnet": [0]}, "params.config.obs_groups", "cfg.yaml")
    with pytest.raises(ConfigError, match=r"obs_groups\.student"):
        parse_dataclass(ObsGroupsConfig, {"student": []}, "params.config.obs_groups", "cfg.yaml")
    with pytest.raises(ConfigError, match=r"obs_groups\.student_dropout"):
        parse_dataclass(ObsGroupsConfig, {"student_dropout": 1.0}, "params.config.obs_groups", "cfg.yaml")


def test_behavior_losses_by_hand():
    box = gym.spaces.Box(-1, 1, (2,), np.float32)
    gauss = DiagGaussian(box, sigma_is_logstd=False, clip_actions=True)
    student = torch.tensor([[0.0, 1.0, 1.0, 1.0]])  # mu (0, 1), std (1, 1)
    teacher = torch.tensor([[1.0, -1.0, 0.5, 0.5]])
    assert float(behavior_loss(gauss, student, teacher, "mse")) == pytest.approx(1.0 + 4.0)
    assert float(behavior_loss(gauss, student, teacher, "huber", 1.0)) == pytest.approx(0.5 + 1.5)
    cat = Categorical(3)
    logits = torch.log(torch.tensor([[0.2, 0.3, 0.5]]))
    assert float(behavior_loss(cat, logits, logits, "kl")) == pytest.approx(0.0, abs=1e-6)
    teacher_logits = torch.log(torch.tensor([[0.7, 0.2, 0.1]]))
    kl = 0.7 * np.log(0.7 / 0.2) + 0.2 * np.log(0.2 / 0.3) + 0.1 * np.log(0.1 / 0.5)
    assert float(behavior_loss(cat, logits, teacher_logits, "kl")) == pytest.approx(kl, rel=1e-5)
    assert float(behavior_loss(cat, logits, teacher_logits, "cross_entropy")) == pytest.approx(-np.log(0.2), rel=1e-5)
    # the loss moves the student only
    student_logits = logits.clone().requires_grad_(True)
    behavior_loss(cat, student_logits, teacher_logits, "kl").sum().backward()
    assert student_logits.grad is not None and float(student_logits.grad.abs().sum()) > 0


def test_resolve_loss():
    assert resolve_loss("auto", True) == "mse" and resolve_loss("auto", False) == "kl"
    with pytest.raises(ValueError, match="loss huber compares continuous action means"):
        resolve_loss("huber", False)


def test_corrupt_adds_noise_and_drops_readings():
    obs = torch.ones(2000, 3)
    assert corrupt(obs, 0.0, 0.0) is obs
    noisy = corrupt(obs, 0.1, 0.0)
    assert float((noisy - obs).std()) == pytest.approx(0.1, rel=0.1)
    dropped = corrupt(obs, 0.0, 0.25)
    assert float((dropped == 0).float().mean()) == pytest.approx(0.25, abs=0.03)


def test_the_aggregated_dataset_puts_rollouts_side_by_side():
    from rlchain.algos.distill.distill import _concat_envs
    a = {"obs": torch.zeros(4, 2, 3), "labels": torch.zeros(4, 2, 5), "resets": torch.zeros(4, 2, dtype=torch.bool),
         "masks": None, "states": (torch.zeros(1, 2, 8), torch.zeros(1, 2, 8))}
    b = {k: (v + 1 if isinstance(v, torch.Tensor) and v.dtype != torch.bool else v) for k, v in a.items()}
    b["states"] = tuple(s + 1 for s in a["states"])
    both = _concat_envs([a, b])
    assert both["obs"].shape == (4, 4, 3) and both["labels"].shape == (4, 4, 5) and both["resets"].shape == (4, 4)
    assert both["states"][0].shape == (1, 4, 8) and float(both["states"][1][0, 3, 0]) == 1.0
    assert float(both["obs"][0, 1, 0]) == 0.0 and float(both["obs"][0, 2, 0]) == 1.0
    assert _concat_envs([a]) is a


def test_the_delay_line_gives_the_observation_of_k_steps_ago_and_restarts_with_episodes():
    from rlchain.algos.distill.distill import DelayLine
    line = DelayLine(2)
    no = torch.zeros(2, dtype=torch.bool)
    out = [line.push(torch.tensor([[float(t)], [10.0 + t]]), torch.tensor([t == 0, t == 0]) | no)[:, 0].tolist()
           for t in range(4)]
    assert out == [[0.0, 10.0], [0.0, 10.0], [0.0, 10.0], [1.0, 11.0]]
    restarted = line.push(torch.tensor([[100.0], [14.0]]), torch.tensor([True, False]))
    assert restarted[:, 0].tolist() == [100.0, 12.0]  # env 0 starts over: its first observation
    assert DelayLine(0).push(torch.ones(1, 1), no[:1]) is not None


def test_a_teacher_path_is_read_as_checkpoint_does(tmp_path):
    # the same rule as --checkpoint (config/packaged.py resolve_checkpoint): a path, nn/<x>.pth or a packaged name
    from rlchain.config.packaged import CHECKPOINTS_DIR
    shipped = os.path.join(CHECKPOINTS_DIR, "cartpole.pth")
    cfg = {"teacher_checkpoint": "cartpole"}  # a packaged name, as `--checkpoint cartpole`
    assert _teacher_path(cfg) == shipped
    assert os.path.samefile(_teacher_path({"teacher_checkpoint": "nn/cartpole.pth"}), shipped)  # any cwd
    mine = tmp_path / "cartpole.pth"
    mine.write_bytes(b"x")
    assert _teacher_path({"teacher_checkpoint": str(mine)}) == str(mine)
    # a missing path of the user's is never swapped for the shipped file of the same name: reported as not found
    missing = str(tmp_path / "runs" / "cartpole.pth")
    assert _teacher_path({"teacher_checkpoint": missing}) == missing


def _teacher_path(cfg: dict) -> str:
    from rlchain.config.packaged import resolve_checkpoint
    return resolve_checkpoint(cfg["teacher_checkpoint"])[0]
