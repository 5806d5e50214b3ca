"""OpenAI gym 0.26 spaces (Isaac Lab's rl_games wrapper returns them) are accepted as gymnasium ones."""

from types import SimpleNamespace

import gymnasium
import numpy as np
import pytest
import torch

gym = pytest.importorskip("gym")  # the test extra installs gym 0.26.2

from rlchain.envs.backends.rl_games_vecenv import IVecEnvAdapter  # noqa: E402
from rlchain.envs.gym_spaces import SpaceError, to_gymnasium  # noqa: E402
from rlchain.rl_games.common.env_configurations import get_env_info  # noqa: E402


def test_every_gym_space_kind_becomes_its_gymnasium_twin():
    box = gym.spaces.Box(-5.0, 5.0, (3,), np.float32)
    cases = {
        "box": (box, gymnasium.spaces.Box(-5.0, 5.0, (3,), np.float32)),
        "discrete": (gym.spaces.Discrete(4), gymnasium.spaces.Discrete(4)),
        "multi": (gym.spaces.MultiDiscrete([2, 3]), gymnasium.spaces.MultiDiscrete([2, 3])),
        "tuple": (gym.spaces.Tuple((box, gym.spaces.Discrete(2))),
                  gymnasium.spaces.Tuple((gymnasium.spaces.Box(-5.0, 5.0, (3,), np.float32),
                                          gymnasium.spaces.Discrete(2)))),
        "dict": (gym.spaces.Dict({"pos": box, "mode": gym.spaces.Discrete(3)}),
                 gymnasium.spaces.Dict({"pos": gymnasium.spaces.Box(-5.0, 5.0, (3,), np.float32),
                                        "mode": gymnasium.spaces.Discrete(3)})),
    }
    for name, (old, new) in cases.items():
        converted = to_gymnasium(old)
        assert isinstance(converted, gymnasium.spaces.Space), name
        assert converted == new, name


def test_gymnasium_spaces_and_none_pass_through_and_others_name_their_class():
    space = gymnasium.spaces.Box(-1, 1, (2,))
    assert to_gymnasium(space) is space and to_gymnasium(None) is None
    with pytest.raises(SpaceError, match=r"gym\.spaces\.graph\.Graph"):
        to_gymnasium(gym.spaces.Graph(gym.spaces.Box(-1, 1, (2,)), None))
    with pytest.raises(SpaceError, match=r"builtins\.str"):
        to_gymnasium("Box(3)")


class GymSpacesVecEnv:
    """An rl_games IVecEnv that reports gym 0.26 spaces, as Isaac Lab's wrapper does."""

    def __init__(self, n: int = 4) -> None:
        self.n = n

    def get_env_info(self) -> dict:
        return {"observation_space": gym.spaces.Box(-5.0, 5.0, (3,), np.float32),
                "action_space": gym.spaces.Box(-1.0, 1.0, (1,), np.float32)}

    def reset(self):
        return {"obs": torch.zeros(self.n, 3)}

    def step(self, actions):
        return {"obs": torch.zeros(self.n, 3)}, torch.zeros(self.n), torch.zeros(self.n, dtype=torch.bool), {}


def test_the_ivecenv_adapter_and_get_env_info_hand_on_gymnasium_spaces():
    env = GymSpacesVecEnv()
    adapter = IVecEnvAdapter(env, 4)
    assert isinstance(adapter.observation_space, gymnasium.spaces.Box)
    assert isinstance(adapter.action_space, gymnasium.spaces.Box)
    info = get_env_info(env)
    assert isinstance(info["action_space"], gymnasium.spaces.Box) and info["agents"] == 1


def test_the_model_builder_takes_gym_spaces(base_config):
    from rlchain.config.load import parse_params
    from rlchain.models.build import build_model

    raw = base_config["params"]
    raw.update(algo={"name": "a2c_continuous"}, model={"name": "continuous_a2c_logstd"})
    raw["network"]["space"] = {"continuous": {"mu_activation": "None", "sigma_activation": "None",
                                              "mu_init": {"name": "default"},
                                              "sigma_init": {"name": "const_initializer", "val": 0},
                                              "fixed_sigma": True}}
    params = parse_params(base_config, "cfg.yaml")
    env = SimpleNamespace(observation_space=gym.spaces.Box(-5.0, 5.0, (3,), np.float32),
                          action_space=gym.spaces.Box(-1.0, 1.0, (1,), np.float32), value_size=1)
    model = build_model(params, env, torch.device("cpu"))
    assert sum(p.numel() for p in model.parameters()) > 0
