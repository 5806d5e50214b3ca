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
    path = model.save(str(tmp_path / "model"))
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
    path = model.save(str(tmp_path / "sac"))
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
    path = model.save(str(tmp_path / "ppo"))
    state = ckpt.read(path)
    state["config"] = {"trainer": {"events": {"train": {"x": {"func": "rlchain_door_payload:run"}}}}}  # EmbodiChain's
    ckpt.save_atomic(state, path)
    with pytest.raises(ConfigError, match="the stored config has no 'params' block"):
        rlchain.PPO.load(path)


def test_sb3_activation_fn_is_stored_by_name_and_read_back_from_torch_only(tmp_path):
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", policy_kwargs={"activation_fn": torch.nn.ReLU, "net_arch": [8]},
                        verbose=0, tensorboard_log=str(tmp_path / "runs"))
    path = model.save(str(tmp_path / "relu"))
    assert rlchain.PPO.load(path).policy_kwargs["activation_fn"] is torch.nn.ReLU
    state = ckpt.read(path)
    assert state["policy_kwargs"]["activation_fn"] == {"__torch_activation__": "ReLU"}  # a name, not a class
    state["policy_kwargs"]["activation_fn"] = {"__torch_activation__": "Module"}
    ckpt.save_atomic(state, path)
    with pytest.raises(ckpt.CheckpointError, match="'Module' is not a torch activation"):
        rlchain.PPO.load(path)
