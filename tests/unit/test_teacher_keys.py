"""rlchain/algos/distill/teacher_keys.py: the keys a distillation's teacher reads of Dict observations kept per
key (obs_groups.teacher, else the keys it was trained on, else all) and its input made of them; a part that is
not a key is a one-line ConfigError naming the file and the key."""

from collections import OrderedDict

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.algos.distill.teacher_keys import TeacherInput, check_encoded, teacher_keys
from rlchain.config.errors import ConfigError
from rlchain.envs.obs_dict import ObsDict

SPACE = gym.spaces.Dict({"image": gym.spaces.Box(0, 255, (1, 8, 8), np.uint8),
                         "proprio": gym.spaces.Box(-np.inf, np.inf, (4,), np.float32),
                         "goal": gym.spaces.Box(-1.0, 1.0, (2,), np.float32)})  # sorted: goal, image, proprio


def keys(chosen=None, trained=None):
    return teacher_keys(SPACE, chosen, trained, "cfg.yaml", "teacher.pth")


def test_the_named_keys_in_their_order_else_the_trained_ones_else_all():
    assert keys(["proprio", "goal"]) == ("proprio", "goal")
    assert keys(None, ["proprio", "goal"]) == ("goal", "proprio")  # as the teacher's flat view was laid out
    assert keys() == ("goal", "image", "proprio")


@pytest.mark.parametrize("chosen, where, what", [
    (["proprio", "gaol"], r"obs_groups\.teacher\[1\]", r"'gaol' is not a key of the observations; did you mean "
                                                          r"'goal'\?; keys: goal, image, proprio"),
    ([0, 2], r"obs_groups\.teacher\[0\]", r"0: the observations are a Dict kept per key .* names keys, not indices"),
    (["goal", "goal"], r"obs_groups\.teacher\[1\]", r"'goal' is named twice"),
])
def test_a_teacher_part_that_is_not_a_key_is_a_one_line_error(chosen, where, what):
    with pytest.raises(ConfigError, match=rf"^cfg\.yaml: params\.config\.{where}: {what}") as info:
        keys(chosen)
    assert "\n" not in str(info.value)


def test_a_teacher_trained_on_indices_must_be_told_its_keys():
    with pytest.raises(ConfigError, match=r"params\.config\.obs_groups\.teacher: the teacher in teacher\.pth was "
                                          r"trained on the parts \[0, 2\] .* name the keys it reads"):
        keys(None, [0, 2])


def test_the_teacher_input_per_key_or_concatenated_in_the_named_order():
    obs = ObsDict({"image": torch.full((3, 1, 8, 8), 7, dtype=torch.uint8), "proprio": torch.arange(12.).view(3, 4),
                   "goal": -torch.arange(6.).view(3, 2)})
    flat = TeacherInput(("proprio", "goal"), per_key=False)
    assert flat.space(SPACE).shape == (6,)
    x = flat(obs)
    assert x.shape == (3, 6) and x[1].tolist() == [4.0, 5.0, 6.0, 7.0, -2.0, -3.0]
    per_key = TeacherInput(("proprio", "goal"), per_key=True)
    sub = per_key.space(gym.spaces.Dict(OrderedDict(SPACE.spaces)))
    assert list(sub.spaces) == ["goal", "proprio"]  # the env's own order, the image left out
    picked = per_key(obs)
    assert isinstance(picked, ObsDict) and set(picked) == {"proprio", "goal"} and picked["goal"] is obs["goal"]


def test_a_multi_input_teacher_must_get_every_key_it_encodes():
    weights = {"a2c_network.actor_cnn.encoders.goal.mlp.0.weight": 0,
               "a2c_network.actor_cnn.encoders.proprio.mlp.0.weight": 0, "a2c_network.mu.weight": 0}
    check_encoded(weights, ("goal", "proprio"), SPACE, True, "cfg.yaml", "t.pth")  # fits: no error
    with pytest.raises(ConfigError, match=r"params\.config\.obs_groups\.teacher: leaves out goal, which the teacher "
                                          r"in t\.pth reads \(it encodes goal, proprio\)"):
        check_encoded(weights, ("proprio",), SPACE, True, "cfg.yaml", "t.pth")
    lacking = gym.spaces.Dict({k: SPACE[k] for k in ("image", "proprio")})
    with pytest.raises(ConfigError, match=r"params\.config\.teacher_checkpoint: the teacher in t\.pth reads goal .* "
                                          r"this run's observations \(image, proprio\) lack"):
        check_encoded(weights, ("image", "proprio"), lacking, False, "cfg.yaml", "t.pth")
