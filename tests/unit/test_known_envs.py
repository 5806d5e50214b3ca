"""rlchain.envs.known: an env name read from a file is looked up in the registries as they are (gymnasium's registry
dict, ale-py's ids, envpool's tasks, PettingZoo's and mpe2's lists, rlchain's ENVS) and never imported; every refusal
is one line naming the file and the key. A module on sys.path writes a marker when imported: it never appears."""

import sys

import pytest

from rlchain.config.errors import ConfigError
from rlchain.envs.backends.pettingzoo_env import known_env_names, resolve_env_module
from rlchain.envs.known import check_stored_env, stored_names
from rlchain.envs.vecenv import register as register_vecenv

IMPORTING = ["1h66mark:X-v0", "h66-mark:X-v0", "h66mark:!", "h66mark:X v0", "h66mark:CartPole-v1", "h66mark"]


@pytest.fixture
def marker(tmp_path, monkeypatch):
    """Modules ``h66mark``, ``1h66mark`` and ``h66-mark`` on sys.path; importing any of them creates the marker."""
    mark = tmp_path / "imported"
    for name in ("h66mark", "1h66mark", "h66-mark"):
        (tmp_path / f"{name}.py").write_text(f"open({str(mark)!r}, 'a').write({name!r})\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield mark
    assert not mark.exists(), "a name from a file was imported"
    assert not {"h66mark", "1h66mark", "h66-mark"} & set(sys.modules)


def everything(key):
    return True


def refused(config, key):
    with pytest.raises(ConfigError) as exc:
        check_stored_env(config, "x.pth", everything)
    text = str(exc.value)
    assert text.startswith(f"x.pth: params.config.{key}: ") and "\n" not in text, text
    return text


@pytest.mark.parametrize("name", IMPORTING)
def test_a_stored_gymnasium_id_that_is_not_registered_is_refused_unimported(marker, name):
    assert "is not an env gymnasium lists" in refused({"env_name": name}, "env_name")
    refused({"env_name": "openai_gym", "env_config": {"name": name}}, "env_config.name")
    refused({"env_name": "gymnasium", "env_config": {"env_name": name}}, "env_config.env_name")
    refused({"env_name": "CartPole-v1", "player": {"env_config": {"wrapped_env_name": name}}},
            "player.env_config.wrapped_env_name")


@pytest.mark.parametrize("name", IMPORTING)
def test_a_stored_atari_or_envpool_name_is_refused_unimported(marker, name):
    assert "ale-py" in refused({"env_name": "atari_gymnasium", "env_config": {"env_name": name}}, "env_config.env_name")
    refused({"env_name": "atari_gym", "env_config": {"name": name}}, "env_config.name")
    assert "envpool" in refused({"env_name": "envpool", "env_config": {"env_name": name}}, "env_config.env_name")
    refused({"env_name": name, "vecenv_type": "envpool"}, "env_name")


@pytest.mark.parametrize("name", ["h66mark", "this", "mpe.h66mark", "classic.h66mark", "os", "1h66mark"])
def test_a_stored_pettingzoo_name_is_refused_unimported(marker, name):
    assert "PettingZoo" in refused({"env_name": "pettingzoo", "env_config": {"env": name}}, "env_config.env")


def test_registered_names_pass():
    ok = [{"env_name": "CartPole-v1"}, {"env_name": "openai_gym", "env_config": {"name": "Pendulum-v1"}},
          {"env_name": "envpool", "env_config": {"env_name": "CartPole-v1"}},
          {"env_name": "atari_gymnasium", "env_config": {"env_name": "ALE/Pong-v5"}},
          {"env_name": "pettingzoo", "env_config": {"env": "classic.connect_four_v3"}},
          {"env_name": "pettingzoo", "env_config": {"env": "mpe.simple_spread_v3"}},
          {"env_name": "pettingzoo", "env_config": {"env": "mpe2.simple_spread_v3"}},
          {"env_name": "TorchCartPole-v0"}, {"env_name": "brax", "env_config": {"env_name": "ant"}}]
    for config in ok:
        check_stored_env(config, "x.pth", everything)


def test_a_users_override_is_theirs():
    config = {"env_name": "pettingzoo", "env_config": {"env": "h66mark"}}
    check_stored_env(config, "x.pth", lambda key: key != "env_config.env")  # the override gave it: not checked here
    with pytest.raises(ConfigError):
        check_stored_env(config, "x.pth", lambda key: key != "env_name")  # the file's env_config.env still is


def test_a_vecenv_type_registered_by_code_takes_the_names(scoped_registries):
    register_vecenv("H66_USER", lambda config_name, num_actors, **kwargs: None)
    assert stored_names({"env_name": "h66mark:X-v0", "vecenv_type": "H66_USER"}) == []
    assert stored_names({"env_name": "h66mark:X-v0", "vecenv_type": "envpool"}) != []


def test_an_entry_that_only_binds_a_vecenv_type_leaves_the_name_a_gymnasium_id(scoped_registries):
    from rlchain import env_configurations

    env_configurations.register("h66mark:X-v0", {"vecenv_type": "RAY"})  # what rl_games' Runner binds
    assert stored_names({"env_name": "h66mark:X-v0"}) == [("env_name", "h66mark:X-v0", "gymnasium")]
    env_configurations.register("h66mark:Y-v0", {"vecenv_creator": lambda num_envs, seed, **kw: None})
    assert stored_names({"env_name": "h66mark:Y-v0"}) == []


def test_pettingzoo_lists_its_envs_and_a_listed_name_resolves_to_its_module(marker, monkeypatch, tmp_path):
    names = known_env_names()
    assert {"classic.connect_four_v3", "pettingzoo.classic.tictactoe_v3", "mpe.simple_tag_v3"} <= names
    assert not {"this", "h66mark"} & names
    (tmp_path / "classic").mkdir()  # a package shadowing the listed name: never imported for it
    (tmp_path / "classic" / "__init__.py").write_text(f"open({str(marker)!r}, 'a').write('classic')\n")
    monkeypatch.delitem(sys.modules, "classic", raising=False)
    assert resolve_env_module("classic.tictactoe_v3").__name__ == "pettingzoo.classic.tictactoe_v3"
