"""No checkpoint grants itself trust or names code that runs: trust comes from the person running the command
(--trust-checkpoint, their --file, a keyword in their call). A data-only checkpoint whose stored config asks
for trust and a watched folder, or stores import_modules, callbacks or an importing env id, runs none of it;
rlchain.PPO / SAC / DQN .load and set_parameters read files as data.
"""

import os
import sys

import pytest
import torch

import rlchain
from rlchain import Runner
from rlchain.cli import main
from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt
from tests.conftest import ROOT

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(ROOT, "rlchain", "checkpoints", "cartpole.pth")


class Payload:
    """Unpickling this calls open(marker, 'w'): code from the file, visible as the marker appearing."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return open, (self.marker, "w")


def data_only(tmp_path, name, edit):
    """The shipped cartpole checkpoint, its stored config changed by ``edit(params)``, saved as data."""
    state = ckpt.load(CARTPOLE)
    edit(state["config"]["params"])
    path = str(tmp_path / name)
    ckpt.save_atomic(state, path)
    assert ckpt.load(path)["format"] == ckpt.FORMAT  # it passes the allow-list: data only
    return path


def test_a_checkpoint_asking_for_trust_and_a_watched_folder_gets_neither(tmp_path, monkeypatch, capsys):
    marker = str(tmp_path / "payload_ran")
    state = ckpt.load(CARTPOLE)
    torch.save({**state, "note": Payload(marker)}, str(tmp_path / "sibling.pth"))  # the payload beside it

    def ask(params):
        params["config"]["trust_checkpoint"] = True
        params["config"]["player"].update(evaluation=True, dir_to_monitor=".")

    path = data_only(tmp_path, "asks.pth", ask)
    monkeypatch.chdir(tmp_path)
    with pytest.warns(UserWarning, match=r"trust_checkpoint, params.config.player.evaluation, "
                                         r"params.config.player.dir_to_monitor not used"):
        code = main(["--play", "--checkpoint", path, "--games", "1", "params.config.device=cpu",
                     "params.config.player.print_stats=false"])
    assert code == 0, capsys.readouterr().err
    assert not os.path.exists(marker)  # played the checkpoint; watched nothing, trusted nothing
    with pytest.warns(UserWarning, match="not used"):
        runner = Runner().load_from_checkpoint(path)
    assert runner.params.config.trust_checkpoint is False and runner.params.config.player.evaluation is False
    # the user's own words still count: an override on the command line is theirs
    with pytest.warns(UserWarning, match="not used"):
        runner = Runner().load_from_checkpoint(path, ["params.config.trust_checkpoint=true"])
    assert runner.params.config.trust_checkpoint is True


def test_a_stored_import_modules_is_not_imported(tmp_path, monkeypatch, capsys):
    marker = tmp_path / "imported"
    (tmp_path / "rlchain_door_payload.py").write_text(f"open({str(marker)!r}, 'w').close()\n")
    monkeypatch.syspath_prepend(str(tmp_path))

    def store(params):
        params["import_modules"] = ["rlchain_door_payload", "this"]
        params["config"]["callbacks"] = ["rlchain_door_payload:Nothing"]

    path = data_only(tmp_path, "imports.pth", store)
    with pytest.warns(UserWarning, match=r"params.import_modules, params.config.callbacks not used"):
        runner = Runner().load_from_checkpoint(path)
    assert not runner.params.import_modules and runner.params.config.callbacks == []
    with pytest.warns(UserWarning, match="not used"):
        assert main(["--play", "--checkpoint", path, "--games", "1", "params.config.device=cpu",
                     "params.config.player.print_stats=false"]) == 0
    assert not marker.exists() and "rlchain_door_payload" not in sys.modules
    assert "Beautiful is better" not in capsys.readouterr().out  # `import this` did not run either


def test_a_stored_env_id_that_imports_a_module_is_refused(tmp_path):
    def importing(params):
        params["config"]["env_name"] = "rlchain_door_payload:Evil-v0"

    path = data_only(tmp_path, "env.pth", importing)
    with pytest.raises(ConfigError, match=r"params.config.env_name: 'rlchain_door_payload:Evil-v0' is not an env "
                                          r"gymnasium lists"):
        Runner().load_from_checkpoint(path)


@pytest.fixture
def sb3_payload(tmp_path):
    """A file rlchain.PPO.save wrote, with a payload added; returns (path, marker)."""
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", seed=1, verbose=0, tensorboard_log=str(tmp_path / "runs"))
    path = model.save(str(tmp_path / "model.pth"))
    marker = str(tmp_path / "payload_ran")
    state = ckpt.read(path)
    torch.save({**state, "note": Payload(marker)}, path)
    return path, marker


@pytest.mark.parametrize("cls", ["PPO", "SAC", "DQN"])
def test_sb3_load_refuses_a_payload(sb3_payload, cls):
    path, marker = sb3_payload
    with pytest.raises(ckpt.CheckpointError, match=r"refused: it names the type 'io.open'") as exc:
        getattr(rlchain, cls).load(path)
    assert "\n" not in str(exc.value)
    assert not os.path.exists(marker)


def test_sb3_set_parameters_refuses_a_payload(sb3_payload, tmp_path):
    path, marker = sb3_payload
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", seed=2, verbose=0, tensorboard_log=str(tmp_path / "runs"))
    with pytest.raises(ckpt.CheckpointError, match="refused"):
        model.set_parameters(path)
    assert not os.path.exists(marker)
    with ckpt.trusting():  # the caller's own keyword: their choice, and the file's code runs
        rlchain.PPO.load(path)
    assert os.path.exists(marker)


def test_sb3_file_is_data_and_its_stored_trust_and_env_are_not_followed(tmp_path):
    model = rlchain.SAC("MlpPolicy", "Pendulum-v1", seed=1, verbose=0, tensorboard_log=str(tmp_path / "runs"))
    path = model.save(str(tmp_path / "sac.pth"))
    state = ckpt.read(path)  # loads with weights_only: no pickled space or class inside
    assert state["spaces"][0]["__space__"] == "Box"
    state["config"]["params"]["config"]["trust_checkpoint"] = True
    state["config"]["params"]["import_modules"] = ["this"]
    ckpt.save_atomic(state, path)
    loaded = rlchain.SAC.load(path)
    assert "import_modules" not in loaded.config["params"]
    assert "trust_checkpoint" not in loaded.config["params"]["config"]
    state["env_id"] = "rlchain_door_payload:Evil-v0"
    ckpt.save_atomic(state, path)
    with pytest.raises(ConfigError, match="env_id: 'rlchain_door_payload:Evil-v0' is not an env gymnasium lists"):
        rlchain.SAC.load(path)


def test_a_stored_config_in_another_layout_is_not_translated(tmp_path):
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", seed=1, verbose=0, tensorboard_log=str(tmp_path / "runs"))
    path = model.save(str(tmp_path / "ppo.pth"))
    state = ckpt.read(path)
    state["config"] = {"trainer": {"events": {"train": {"x": {"func": "rlchain_door_payload:run"}}}}}  # EmbodiChain's
    ckpt.save_atomic(state, path)
    with pytest.raises(ConfigError, match="the stored config has no 'params' block"):
        rlchain.PPO.load(path)


def test_sb3_activation_fn_is_stored_by_name_and_read_back_from_torch_only(tmp_path):
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", policy_kwargs={"activation_fn": torch.nn.ReLU, "net_arch": [8]},
                        verbose=0, tensorboard_log=str(tmp_path / "runs"))
    path = model.save(str(tmp_path / "relu.pth"))
    assert rlchain.PPO.load(path).policy_kwargs["activation_fn"] is torch.nn.ReLU
    state = ckpt.read(path)
    assert state["policy_kwargs"]["activation_fn"] == {"__torch_activation__": "ReLU"}  # a name, not a class
    state["policy_kwargs"]["activation_fn"] = {"__torch_activation__": "Module"}
    ckpt.save_atomic(state, path)
    with pytest.raises(ckpt.CheckpointError, match="'Module' is not a torch activation"):
        rlchain.PPO.load(path)


@pytest.fixture
def importable(tmp_path, monkeypatch):
    """Modules on sys.path whose import writes a marker (the names a file could give); returns the marker."""
    marker = tmp_path / "imported"
    for name in ("rlchain_door_env", "1rlchain_door_env", "rlchain-door-env"):
        (tmp_path / f"{name}.py").write_text(f"open({str(marker)!r}, 'a').write({name!r})\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)  # `python -m` and notebooks put the current folder on sys.path
    return marker


@pytest.mark.parametrize(("env_name", "env_config", "key"), [
    ("pettingzoo", {"env": "rlchain_door_env"}, "env_config.env"),
    ("pettingzoo", {"env": "this"}, "env_config.env"),
    ("atari_gymnasium", {"env_name": "1rlchain_door_env:X-v0"}, "env_config.env_name"),
    ("openai_gym", {"name": "rlchain-door-env:X-v0"}, "env_config.name"),
    ("rlchain_door_env:X v0", {}, "env_name"),
])
def test_a_stored_env_name_is_never_imported(tmp_path, importable, capsys, env_name, env_config, key):
    def store(params):
        params["config"].update(env_name=env_name, env_config=env_config)

    path = data_only(tmp_path, "env.pth", store)
    with pytest.raises(ConfigError, match=rf"env.pth: params.config.{key}: .* is not an env .* lists"):
        Runner().load_from_checkpoint(path)
    for argv in (["--play", "--checkpoint", path, "--games", "1"],
                 ["--export", "onnx", "--checkpoint", path, "--output", str(tmp_path / "x.onnx")]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith(f"config error: {path}: params.config.{key}: ") and len(err.splitlines()) == 1, err
    assert not importable.exists() and "rlchain_door_env" not in sys.modules
    assert "Beautiful is better" not in capsys.readouterr().out


def test_the_users_override_and_file_keep_their_powers(tmp_path, importable):
    def store(params):
        params["config"].update(env_name="pettingzoo", env_config={"env": "rlchain_door_env"})

    path = data_only(tmp_path, "env.pth", store)
    runner = Runner().load_from_checkpoint(path, ["params.config.env_name=CartPole-v1", "params.config.env_config={}"])
    assert runner.params.config.env_name == "CartPole-v1"  # the user's override replaced the file's name
    (tmp_path / "rlchain_door_gym.py").write_text(
        f"import gymnasium\nopen({str(importable)!r}, 'a').write('user')\n"
        "gymnasium.register('DoorCartPole-v0', entry_point='gymnasium.envs.classic_control:CartPoleEnv')\n")
    from rlchain.models.build import build_env

    raw = ckpt.load(CARTPOLE)["config"]  # the user's own config imports their module, which registers their env
    raw["params"]["import_modules"] = ["rlchain_door_gym"]
    raw["params"]["config"].update(env_name="DoorCartPole-v0", device="cpu")
    params = Runner().load({"params": raw["params"]}).params
    build_env(params, 1, 0).close()
    assert importable.read_text() == "user"


@pytest.mark.parametrize("env_id", ["1rlchain_door_env:X-v0", "rlchain-door-env:X-v0", "rlchain_door_env:!",
                                    "rlchain_door_env:X v0"])
def test_an_sb3_files_env_id_is_never_imported(tmp_path, importable, env_id):
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", seed=1, verbose=0, policy_kwargs={"net_arch": [8]})
    path = model.save(str(tmp_path / "model.pth"))
    state = ckpt.read(path)
    state["env_id"] = env_id
    ckpt.save_atomic(state, path)
    with pytest.raises(ConfigError) as exc:
        rlchain.PPO.load(path).get_env()
    assert str(exc.value).startswith(f"{path}: env_id: '{env_id}' is not an env gymnasium lists")
    assert "\n" not in str(exc.value) and not importable.exists()
    assert rlchain.PPO.load(path, env="CartPole-v1").env_source.env_name == "CartPole-v1"  # the caller's env
