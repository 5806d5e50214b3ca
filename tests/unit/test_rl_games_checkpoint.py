"""rl_games checkpoints in and out (rlchain.runs.rl_games_checkpoint) on files real rl_games 1.6.5 and 2.0
wrote (tests/data/rl_games/make_checkpoints.py made them and the actions rl_games' player took)."""

import copy
import os
import sys

import gymnasium
import numpy as np
import pytest
import torch

from rlchain.rl_games.algos_torch import torch_ext
from rlchain.rl_games.algos_torch.players import PpoPlayerContinuous, PpoPlayerDiscrete
from rlchain.runs import checkpoint as ckpt
from rlchain.runs import rl_games_checkpoint as rlg

DATA = os.path.join(os.path.dirname(__file__), "..", "data", "rl_games")
sys.path.insert(0, DATA)
from make_checkpoints import ACTIONS, CONFIGS, KINDS, OBS  # noqa: E402

CASES = [(tag, kind) for tag in ("v165", "v20") for kind in KINDS]


def _player(kind):
    params = copy.deepcopy(CONFIGS[kind]["params"])
    action = (gymnasium.spaces.Box(-1.0, 1.0, (ACTIONS,), np.float32) if kind != "discrete"
              else gymnasium.spaces.Discrete(ACTIONS))
    params["config"]["env_info"] = {"observation_space": gymnasium.spaces.Box(-np.inf, np.inf, (OBS,)),
                                    "action_space": action}
    cls = PpoPlayerContinuous if kind != "discrete" else PpoPlayerDiscrete
    return cls(params)  # built as rl_games builds a player: one argument


@pytest.mark.parametrize("tag,kind", CASES)
def test_rlchain_plays_an_rl_games_checkpoint_as_rl_games_does(tag, kind):
    player = _player(kind)
    player.restore(os.path.join(DATA, f"{tag}_{kind}.pth"))
    expected = torch.load(os.path.join(DATA, f"{tag}_{kind}_actions.pt"), weights_only=True)
    player.get_batch_size(expected["obs"], 1)
    with torch.no_grad():
        actions = player.get_action(expected["obs"], is_deterministic=True)
    assert torch.allclose(torch.as_tensor(actions).float().reshape(expected["actions"].shape),
                          expected["actions"], atol=1e-5)


@pytest.mark.parametrize("tag,kind", CASES)
def test_the_loader_reads_counters_and_the_writer_gives_rl_games_its_names_back(tag, kind):
    path = os.path.join(DATA, f"{tag}_{kind}.pth")
    state = ckpt.load(path)
    assert state["origin"] == rlg.ORIGIN and (state["epoch"], state["frames"]) == (2, 64)
    original = rlg.strip_compiled(torch_ext.load_checkpoint(path)["model"])
    back = rlg.to_rl_games({**state, "agent": {"optimizer": state["rl_games_optimizer"]["state_dict"]}})
    assert list(back["model"]) == list(original)
    assert all(torch.equal(back["model"][k], original[k]) for k in original)
    assert (back["epoch"], back["frame"]) == (2, 64)


def test_an_rl_games_network_rlchain_does_not_convert_is_a_one_line_error(tmp_path):
    state = torch_ext.load_checkpoint(os.path.join(DATA, "v165_discrete.pth"))
    state["model"]["a2c_network.rnn.rnn.weight_ih_l0"] = torch.zeros(4, 8)
    torch_ext.save_checkpoint(str(tmp_path / "rnn"), state)
    with pytest.raises(ckpt.CheckpointError, match=r"rnn\.pth: an rl_games checkpoint rlchain cannot read: "
                                                   r"'a2c_network\.rnn\.rnn\.weight_ih_l0' has no rlchain name"):
        ckpt.load(str(tmp_path / "rnn.pth"))


def test_torch_ext_save_and_load_checkpoint_round_trip(tmp_path):
    state = {"model": {"w": torch.arange(3.0)}, "epoch": 4, "last_mean_rewards": np.float32(1.5)}
    torch_ext.save_checkpoint(str(tmp_path / "run"), state)  # rl_games appends .pth
    loaded = torch_ext.load_checkpoint(str(tmp_path / "run.pth"))
    assert torch.equal(loaded["model"]["w"], state["model"]["w"]) and loaded["epoch"] == 4
    assert float(loaded["last_mean_rewards"]) == 1.5


def test_export_rl_games_writes_what_rl_games_reads(tmp_path):
    from rlchain.cli import main

    rlchain_file = str(tmp_path / "rlchain.pth")
    ckpt.save_atomic(ckpt.load(os.path.join(DATA, "v20_continuous.pth")), rlchain_file)
    assert main(["--export", "rl_games", "--checkpoint", rlchain_file, "--output", str(tmp_path / "out.pth")]) == 0
    written = torch_ext.load_checkpoint(str(tmp_path / "out.pth"))
    original = rlg.strip_compiled(torch_ext.load_checkpoint(os.path.join(DATA, "v20_continuous.pth"))["model"])
    assert set(written) >= {"model", "epoch", "frame", "last_mean_rewards"}
    assert all(torch.equal(written["model"][k], original[k]) for k in original) and written["epoch"] == 2
