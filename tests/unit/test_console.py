"""rlchain.config.packaged (configs and checkpoints by name) and rlchain.console (the ``rlchain`` command's
dispatch), without training: names resolve to the packaged files, bad names and commands are one line."""

from __future__ import annotations

import os
import sys
import types

import pytest

from rlchain import console
from rlchain.config.errors import ConfigError
from rlchain.config.packaged import (
    CHECKPOINTS_DIR,
    CONFIGS_DIR,
    checkpoint_names,
    config_names,
    resolve_checkpoint,
    resolve_config,
)


def test_config_names_cover_the_tree_with_short_aliases():
    names = config_names()
    assert names["ppo_cartpole"] == os.path.join(CONFIGS_DIR, "ppo_cartpole.yaml")
    assert names["push_cube"] == os.path.join(CONFIGS_DIR, "push_cube", "train_config.json")  # a folder of one
    assert names["tune/tune_cartpole"] == names["tune_cartpole"]  # a unique file name works alone
    assert names["halfcheetah_envpool"] == os.path.join(CONFIGS_DIR, "rl_games", "halfcheetah_envpool.yaml")
    # a name taken at the top stays the top's: rl_games' own copy needs its folder
    assert names["ppo_cartpole"] != names["rl_games/ppo_cartpole"]
    assert all(os.path.isfile(path) for path in names.values())


def test_resolve_config_prefers_an_existing_path(tmp_path, monkeypatch):
    own = tmp_path / "ppo_cartpole"
    own.write_text("params: {}\n")
    monkeypatch.chdir(tmp_path)
    assert resolve_config("ppo_cartpole") == "ppo_cartpole"  # the file here wins over the packaged name
    assert resolve_config("ppo_pendulum.yaml") == config_names()["ppo_pendulum"]


def test_an_rlchain_path_outside_a_clone_reads_the_package(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert resolve_config("rlchain/configs/push_cube/train_config.json") == config_names()["push_cube"]
    assert resolve_checkpoint("rlchain/checkpoints/cartpole.pth") == (os.path.join(CHECKPOINTS_DIR,
                                                                                     "cartpole.pth"), True)


def test_unknown_config_is_one_line_with_close_matches(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as err:
        resolve_config("ppo_cartpol")
    message = str(err.value)
    assert "\n" not in message and message.startswith("ppo_cartpol: config file not found")
    assert "'ppo_cartpole'" in message and "rlchain list" in message
    with pytest.raises(ConfigError, match="config file not found"):
        resolve_config("somewhere/none.yaml")


def test_checkpoint_names(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert set(checkpoint_names()) >= {"cartpole", "pendulum", "push_cube"}
    assert resolve_checkpoint("cartpole") == (checkpoint_names()["cartpole"], True)
    assert resolve_checkpoint("pendulum.pth") == (checkpoint_names()["pendulum"], True)
    assert resolve_checkpoint("runs/x/nn/x.pth") == ("runs/x/nn/x.pth", False)  # the loader says not found
    # the README's nn/X.pth where nn/ is not there (a wheel) or is a plain file (git without links, Windows)
    assert resolve_checkpoint("nn/cartpole.pth") == (checkpoint_names()["cartpole"], True)
    (tmp_path / "nn").write_text("rlchain/checkpoints")
    assert resolve_checkpoint("nn\\pendulum.pth") == (checkpoint_names()["pendulum"], True)
    assert resolve_checkpoint("nn/nothing.pth") == ("nn/nothing.pth", False)
    (tmp_path / "cartpole").write_bytes(b"")
    assert resolve_checkpoint("cartpole") == ("cartpole", False)


def test_subcommands_become_runner_flags(monkeypatch):
    calls = []
    fake = types.SimpleNamespace(main=lambda argv, prog, command=None: calls.append((argv, prog)) or 0)
    monkeypatch.setattr(console, "_cli", lambda: fake)
    assert console.main(["train", "ppo_cartpole", "params.config.max_epochs=2", "--seed", "3"]) == 0
    assert console.main(["play", "--checkpoint", "cartpole", "--games", "2"]) == 0
    assert console.main(["export", "onnx", "ppo_cartpole", "-c", "cartpole"]) == 0
    assert console.main(["tune", "tune_cartpole", "-o", "best.yaml"]) == 0
    assert console.main(["-t", "-f", "ppo_cartpole"]) == 0
    assert calls == [
        (["--train", "--file", "ppo_cartpole", "params.config.max_epochs=2", "--seed", "3"], "rlchain train"),
        (["--play", "--checkpoint", "cartpole", "--games", "2"], "rlchain play"),
        (["--export", "onnx", "--file", "ppo_cartpole", "-c", "cartpole"], "rlchain export onnx"),
        (["--tune", "tune_cartpole", "-o", "best.yaml"], "rlchain tune"),
        (["-t", "-f", "ppo_cartpole"], "rlchain"),
    ]


def test_bad_commands_are_one_line(capsys):
    assert console.main(["frob"]) == 2
    assert console.main(["export", "--checkpoint", "cartpole"]) == 2
    assert console.main([]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and "unknown command 'frob'" in err[0] and "export onnx" in err[1]


def test_list_names_each_config_once(capsys):
    assert console.main(["list"]) == 0
    out = capsys.readouterr().out
    assert "  ppo_cartpole " in out and "push_cube/train_config.json" in out and "  cartpole " in out
    assert out.count("rl_games/halfcheetah_envpool.yaml") == 1


def test_compare_imports_its_module_on_use(monkeypatch, capsys):
    seen = []
    fake = types.ModuleType("rlchain.compare.cli")
    fake.main = lambda argv: seen.append(argv) or 0
    monkeypatch.setitem(sys.modules, "rlchain.compare.cli", fake)
    assert console.main(["compare", "runs/a*", "--out", "x"]) == 0
    assert seen == [["runs/a*", "--out", "x"]]


def test_compare_missing_is_one_line(monkeypatch, capsys):
    def missing(name):
        raise ModuleNotFoundError(f"No module named '{name}'", name=name)

    monkeypatch.setattr(console.importlib, "import_module", missing)
    assert console.main(["compare", "runs"]) == 2
    assert capsys.readouterr().err == ("error: rlchain compare is not part of this rlchain install "
                                       "(no module rlchain.compare.cli)\n")


def test_a_mistyped_shipped_checkpoint_is_named(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert console.main(["play", "--checkpoint", "cartpol"]) == 2
    assert capsys.readouterr().err == ("checkpoint error: cartpol: checkpoint not found, and no shipped checkpoint "
                                       "has that name; did you mean 'cartpole'?\n")


@pytest.mark.parametrize("args", [["--help"], ["list"]])
def test_help_and_list_answer_without_torch(args):
    """`rlchain --help` and `rlchain list` import no torch: they answer in well under half a second (the bound
    here is generous for a loaded CI machine; the import check is the exact one)."""
    import subprocess
    import time

    code = ("import sys, runpy; sys.argv = ['rlchain', *sys.argv[1:]]\n"
            "try:\n    runpy.run_module('rlchain', run_name='__main__')\nexcept SystemExit:\n    pass\n"
            "assert 'torch' not in sys.modules, 'torch was imported'\n")
    start = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=120,
                         cwd=os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    seconds = time.perf_counter() - start
    assert out.returncode == 0, out.stderr
    assert ("usage: rlchain COMMAND" if args == ["--help"] else "configs (rlchain train NAME)") in out.stdout
    assert seconds < 5.0, f"rlchain {' '.join(args)} took {seconds:.2f} s"
