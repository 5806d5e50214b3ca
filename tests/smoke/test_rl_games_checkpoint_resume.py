"""rl_games checkpoints with a recurrent, convolutional or SAC network, written by real rl_games 1.6.5 / 2.0
(tests/data/rl_games), fine-tuned one epoch by rlchain under the launcher with make_checkpoints.py's own
training code, then written back for rl_games (``--export rl_games``)."""

import copy
import glob
import os
import sys

import pytest
import torch

from rlchain.rl_games import alias
from rlchain.runs import checkpoint as ckpt
from tests.conftest import ROOT

DATA = os.path.join(ROOT, "tests", "data", "rl_games")


@pytest.mark.parametrize("tag,kind", [("v165", "lstm"), ("v20", "gru_separate"), ("v20", "cnn"),
                                      ("v165", "resnet_lstm"), ("v20", "layer_norm"), ("v165", "central_value"),
                                      ("v165", "sac"), ("v20", "sac_layer_norm"),
                                      ("v165", "layer_norm")])
def test_an_rl_games_checkpoint_fine_tunes_one_epoch_and_exports(tag, kind, tmp_path, monkeypatch,
                                                                 scoped_registries):
    pytest.importorskip("gym")
    monkeypatch.syspath_prepend(DATA)
    source = os.path.join(DATA, f"{tag}_{kind}.pth")
    start = ckpt.load(source)
    alias.install()
    try:
        import make_checkpoints
        from rl_games.common import env_configurations, vecenv
        from rl_games.torch_runner import Runner

        env_class = make_checkpoints.make_env_class(kind)
        vecenv.register("TINY", lambda config_name, num_actors, **kwargs: env_class(num_actors))
        env_configurations.register("tiny_env", {"vecenv_type": "TINY", "env_creator": lambda **kwargs: env_class(4)})
        cfg = copy.deepcopy(make_checkpoints.CONFIGS[kind])
        cfg["params"]["config"].update(train_dir=str(tmp_path), max_epochs=start["epoch"] + 1)
        if "normalization" in cfg["params"]["network"]:  # rl_games 2.0's order
            cfg["params"]["network"]["mlp"]["norm_after_activation"] = True
        runner = Runner()
        runner.load(cfg)
        result = runner.run({"train": True, "checkpoint": source})
        if (tag, kind) == ("v165", "layer_norm"):  # 1.6.5 built no norm layers: the run's own file says so
            first = sorted(glob.glob(os.path.join(str(tmp_path), "**", "*.pth"), recursive=True),
                           key=os.path.getmtime)[-1]
            assert ckpt.load(first)[ckpt.NORMS_DROPPED]
            cfg["params"]["config"]["max_epochs"] = start["epoch"] + 2  # and resumes with the same config
            runner = Runner()
            runner.load(cfg)
            result = runner.run({"train": True, "checkpoint": first})
            cfg["params"]["config"]["player"] = {"games_num": 2}  # and plays with it
            runner = Runner()
            runner.load(cfg)
            assert runner.run({"play": True, "checkpoint": first}).games == 2
            start["epoch"] += 1  # the checks below: of this second run
    finally:
        alias.uninstall()
        sys.modules.pop("make_checkpoints", None)
    assert result.epoch == start["epoch"] + 1 and result.frames > start["frames"]  # rl_games' counters carried on
    written = sorted(glob.glob(os.path.join(str(tmp_path), "**", "*.pth"), recursive=True), key=os.path.getmtime)[-1]
    state = ckpt.load(written)
    assert state["epoch"] == start["epoch"] + 1
    changed = [k for k, v in start["model"].items() if k in state["model"] and not torch.equal(v, state["model"][k])]
    assert changed  # it trained from the rl_games weights

    from rlchain.cli import main

    out = str(tmp_path / "back.pth")
    assert main(["--export", "rl_games", "--checkpoint", written, "--output", out]) == 0
    back = torch.load(out, weights_only=True)
    assert back["epoch"] == start["epoch"] + 1
    original = torch.load(source, weights_only=True)
    if kind.startswith("sac"):  # rl_games' SAC layout: the three networks under their names, the three optimizers
        assert all(list(back[part]) == list(original[part]) for part in ("actor", "critic", "critic_target"))
        assert {"actor_optimizer", "critic_optimizer", "log_alpha_optimizer", "log_alpha"} <= set(back)
    else:
        assert list(back["model"]) == [k.replace("_orig_mod.", "") for k in original["model"]]
        assert len(back["optimizer"]["state"]) == len(original["optimizer"]["state"])
    if kind == "central_value":  # the asymmetric critic trained on and went back under rl_games' names
        assert not torch.equal(state["central_value"]["a2c_network.value.weight"],
                               start["central_value"]["a2c_network.value.weight"])
        assert list(back["assymetric_vf_nets"]) == [k.replace("_orig_mod.", "") for k in original["assymetric_vf_nets"]]
        assert len(back["assymetric_vf_optimizer"]["state"]) == 4
