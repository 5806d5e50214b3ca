"""A config error the face's rlchain run raises names the user's config (``DQNConfig``, ``PPOConfig``) as its
source, not the rlchain dict the face translated it into (``<dict>``, what ``Runner.load`` of a dict says)."""

import copy

import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.dqn import DQNConfig
from rlchain.runner import Runner
from tests.unit.test_config_frozen import BASE


def test_runner_load_names_a_dicts_source_as_told():
    raw = copy.deepcopy(BASE)
    raw["params"]["import_modules"] = ["no_such_pkg_h68p"]
    with pytest.raises(ConfigError, match=r"^MyConfig: params.import_modules: cannot import"):
        Runner().load(copy.deepcopy(raw), source="MyConfig")
    with pytest.raises(ConfigError, match=r"^<dict>: params.import_modules"):  # a dict told nothing
        Runner().load(raw)


def test_an_error_of_the_faces_run_names_the_users_config(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = DQNConfig().environment("CartPole-v1").training(
        replay_buffer_config={"type": "PrioritizedEpisodeReplayBuffer", "capacity": 10**13})
    with pytest.raises(ConfigError, match=r"^DQNConfig: params.config.replay_buffer_size: the replay buffer") as info:
        config.build_algo()
    assert "<dict>" not in str(info.value) and "\n" not in str(info.value)
