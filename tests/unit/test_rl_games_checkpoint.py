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
from rlchain.rl_games.algos_torch.players import PpoPlayerContinuous, PpoPlayerDiscrete, SACPlayer
from rlchain.runs import checkpoint as ckpt
from rlchain.runs import rl_games_checkpoint as rlg

DATA = os.path.join(os.path.dirname(__file__), "..", "data", "rl_games")
sys.path.insert(0, DATA)
import make_checkpoints as made  # noqa: E402

ACTIONS, CONFIGS, KINDS, MULTI, RNN_KINDS = made.ACTIONS, made.CONFIGS, made.KINDS, made.MULTI, made.RNN_KINDS
is_continuous, obs_shape, player_actions = made.is_continuous, made.obs_shape, made.player_actions

CASES = [(tag, kind) for tag in ("v165", "v20") for kind in KINDS]


def _params(tag, kind, as_written=False):
    """The config the file was trained with, as rlchain reads it: rl_games 2.0 normalizes after the activation
    (``mlp.norm_after_activation``), rl_games 1.6.5 builds no MLP normalization layers (the key dropped)."""
    params = copy.deepcopy(CONFIGS[kind]["params"])
    if "normalization" in params["network"] and not as_written:
        if tag == "v165":
            del params["network"]["normalization"]
        else:
            params["network"]["mlp"]["norm_after_activation"] = True
    return params


def _player(tag, kind, as_written=False):
    params = _params(tag, kind, as_written)
    action = (gymnasium.spaces.Box(-1.0, 1.0, (ACTIONS,), np.float32) if is_continuous(kind)
              else gymnasium.spaces.Tuple([gymnasium.spaces.Discrete(n) for n in MULTI]) if kind == "multi_discrete"
              else gymnasium.spaces.Discrete(ACTIONS))
    params["config"]["env_info"] = {"observation_space": gymnasium.spaces.Box(-np.inf, np.inf, obs_shape(kind)),
                                    "action_space": action}
    cls = SACPlayer if kind.startswith("sac") else PpoPlayerContinuous if is_continuous(kind) else PpoPlayerDiscrete
    return cls(params)  # built as rl_games builds a player: one argument


@pytest.mark.parametrize("tag,kind", CASES)
def test_rlchain_plays_an_rl_games_checkpoint_as_rl_games_does(tag, kind):
    player = _player(tag, kind)
    player.restore(os.path.join(DATA, f"{tag}_{kind}.pth"))
    expected = torch.load(os.path.join(DATA, f"{tag}_{kind}_actions.pt"), weights_only=True)
    actions = player_actions(player, kind)  # from zero states, three steps in a row for an RNN
    assert torch.allclose(actions.reshape(expected["actions"].shape), expected["actions"], atol=1e-5)


def _rl_games_agent(state):
    return dict(state["rl_games_optimizers"])


@pytest.mark.parametrize("tag,kind", CASES)
def test_the_loader_reads_counters_and_the_writer_gives_rl_games_its_names_back(tag, kind):
    path = os.path.join(DATA, f"{tag}_{kind}.pth")
    state = ckpt.load(path)
    sac = kind.startswith("sac")
    counters = (4, 64) if sac else (2, 64)
    assert state["origin"] == rlg.ORIGIN and (state["epoch"], state["frames"]) == counters
    raw = torch_ext.load_checkpoint(path)
    back = rlg.to_rl_games({**state, "agent": _rl_games_agent(state)})
    parts = ("actor", "critic", "critic_target", "running_mean_std") if sac else ("model",)
    for part in parts:
        original = rlg.strip_compiled(raw[part])
        assert list(back[part]) == list(original)
        assert all(torch.equal(back[part][k], original[k]) for k in original)
    assert (back["epoch"], back["frame"]) == counters
    if not sac:  # the optimizer's per-parameter state goes back to each parameter's rl_games position
        for i, moments in raw["optimizer"]["state"].items():
            assert torch.equal(back["optimizer"]["state"][i]["exp_avg"], moments["exp_avg"])


@pytest.mark.parametrize("tag", ["v165", "v20"])
def test_an_rl_games_central_value_maps_onto_rlchain_and_back(tag):
    path = os.path.join(DATA, f"{tag}_central_value.pth")
    state = ckpt.load(path)
    assert {"a2c_network.actor_mlp.0.weight", "a2c_network.value.bias", "running_mean_std.running_mean",
            "value_mean_std.running_var"} <= set(state["central_value"])
    agent = {"optimizer": state["rl_games_optimizers"]["optimizer"]}
    cv_agent = {"optimizer": state["rl_games_cv_optimizer"]}
    back = rlg.to_rl_games({**state, "agent": agent, "central_value_agent": cv_agent})
    raw = torch_ext.load_checkpoint(path)
    original = rlg.strip_compiled(raw["assymetric_vf_nets"])
    assert list(back["assymetric_vf_nets"]) == list(original)  # uncompiled names: rl_games compiles after restoring
    assert all(torch.equal(back["assymetric_vf_nets"][k], original[k]) for k in original)
    assert torch.equal(back["assymetric_vf_optimizer"]["state"][2]["exp_avg"],
                       raw["assymetric_vf_optimizer"]["state"][2]["exp_avg"])


@pytest.mark.parametrize("tag,kind", CASES)
def test_rlchain_builds_the_files_tensors_under_their_rl_games_names(tag, kind):
    player = _player(tag, kind)
    own = {k: tuple(v.shape) for k, v in player.policy.state_dict().items()}
    state = ckpt.load(os.path.join(DATA, f"{tag}_{kind}.pth"))
    saved = {k: tuple(v.shape) for k, v in state["model"].items()}
    assert {k: v for k, v in own.items() if k not in state.get("keep_built", ())} == saved


def test_an_rl_games_sac_checkpoint_maps_onto_rlchain_sac():
    state = ckpt.load(os.path.join(DATA, "v20_sac.pth"))
    model = state["model"]
    assert {"network.actor.trunk.2.weight", "network.actor.trunk.4.weight", "network.critic.Q2.4.bias",
            "critic_target.Q1.0.weight", "running_mean_std.running_var", "log_alpha"} <= set(model)
    assert model["network.actor.trunk.4.weight"].shape == (2 * ACTIONS, 8)
    # rl_games 1.6.5 keeps no temperature: the model keeps the one its config starts from
    assert ckpt.load(os.path.join(DATA, "v165_sac.pth"))["keep_built"] == ["log_alpha"]


def test_an_rl_games_network_rlchain_does_not_build_is_a_one_line_error(tmp_path):
    state = torch_ext.load_checkpoint(os.path.join(DATA, "v165_discrete.pth"))
    state["model"]["a2c_network.d2rl.0.weight"] = torch.zeros(4, 8)
    torch_ext.save_checkpoint(str(tmp_path / "other"), state)
    with pytest.raises(ckpt.CheckpointError, match=r"other\.pth: checkpoint does not match this model's network "
                                                   r"\(unexpected \['a2c_network\.d2rl\.0\.weight'\]\)"):
        _player("v165", "discrete").restore(str(tmp_path / "other.pth"))


@pytest.mark.parametrize("kind", ["layer_norm", "sac_layer_norm"])
def test_rl_games_2_normalization_layers_map_after_the_activation(kind):
    model = ckpt.load(os.path.join(DATA, f"v20_{kind}.pth"))["model"]
    norm = "a2c_network.actor_mlp.5.weight" if kind == "layer_norm" else "network.critic.Q2.5.bias"
    assert norm in model and model[norm].shape == (8,)


def test_rl_games_2_normalization_without_norm_after_activation_says_to_set_it():
    player = _player("v20", "layer_norm", as_written=True)
    with pytest.raises(ckpt.CheckpointError, match=r"v20_layer_norm\.pth: checkpoint does not match .* normalizes "
                                                   r"after the activation .*: set "
                                                   r"network\.mlp\.norm_after_activation: True"):
        player.restore(os.path.join(DATA, "v20_layer_norm.pth"))


def test_rl_games_1_6_5_normalization_config_is_ignored_with_one_warning(caplog):
    player = _player("v165", "layer_norm", as_written=True)  # the config keeps network.normalization
    with caplog.at_level("WARNING", logger="rlchain"):
        player.restore(os.path.join(DATA, "v165_layer_norm.pth"))
    lines = [r.getMessage() for r in caplog.records if "1.6.5 builds no MLP normalization" in r.getMessage()]
    assert len(lines) == 1 and "\n" not in lines[0] and "v165_layer_norm.pth" in lines[0]
    assert not any(isinstance(m, torch.nn.LayerNorm) for m in player.model.modules())  # as 1.6.5 built it
    expected = torch.load(os.path.join(DATA, "v165_layer_norm_actions.pt"), weights_only=True)
    actions = player_actions(player, "layer_norm")  # rl_games 1.6.5's own player's actions on this file
    assert torch.allclose(actions.reshape(expected["actions"].shape), expected["actions"], atol=1e-5)


def test_norm_after_activation_builds_rl_games_order():
    from rlchain.config.network import MlpConfig
    from rlchain.networks.mlp import MLP

    after = MLP(3, MlpConfig(units=[4], normalization="layer_norm", norm_after_activation=True))
    before = MLP(3, MlpConfig(units=[4], normalization="layer_norm"))
    assert [type(m).__name__ for m in after] == ["Linear", "ELU", "LayerNorm"]
    assert [type(m).__name__ for m in before] == ["Linear", "LayerNorm", "ELU"]


def test_rlchain_normalization_layers_are_not_exported_for_rl_games():
    state = ckpt.load(os.path.join(DATA, "v165_continuous.pth"))
    state["model"]["a2c_network.actor_mlp.1.weight"] = torch.ones(8)
    with pytest.raises(ValueError, match=r"'a2c_network\.actor_mlp\.1\.weight' is a normalization "
                                         r"layer before the activation .* rl_games cannot compute this network"):
        rlg.to_rl_games(state)


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


def test_a_multi_discrete_head_keeps_one_linear_per_dimension_both_ways():
    state = ckpt.load(os.path.join(DATA, "v20_multi_discrete.pth"))
    assert [state["model"][f"a2c_network.logits.{i}.weight"].shape for i in range(len(MULTI))] == \
        [(n, 8) for n in MULTI]
    trained = {k: v for k, v in state.items() if k != "origin"}  # as rlchain saves it after training
    assert rlg.to_rl_games(trained)["model"] is not None


@pytest.mark.parametrize("tag", ["v165", "v20"])
def test_sac_player_holds_rl_games_sac_model(tag):
    player = _player(tag, "sac")
    player.restore(os.path.join(DATA, f"{tag}_sac.pth"))
    model, obs = player.model, made.fixed_obs("sac")
    dist = model.actor(model.norm_obs(obs))  # rl_games 2.0's SAC player test reads the model this way
    expected = torch.load(os.path.join(DATA, f"{tag}_sac_actions.pt"), weights_only=True)["actions"]
    assert torch.allclose(player.rescale_actions(dist.mean), expected.reshape(dist.mean.shape), atol=1e-5)
    assert torch.equal(model({"obs": model.norm_obs(obs)}).mean, dist.mean) and not model.is_rnn()
    for part in ("critic", "critic_target"):
        q1, q2 = getattr(model, part)(model.norm_obs(obs), dist.mean)
        assert q1.shape == q2.shape == (len(obs), 1)  # as rl_games' critics return them
    parts, policy = model.sac_network, player.policy  # rlchain's modules, restored once for both
    assert (parts.actor, parts.critic, parts.critic_target) == (policy.network.actor, policy.network.critic,
                                                                policy.critic_target)
    assert player.actions_num == ACTIONS and torch.equal(player.action_bias, torch.zeros(ACTIONS))


def test_a_checkpoint_continuing_a_1_6_5_run_reloads_with_the_same_config(tmp_path, caplog):
    player = _player("v165", "layer_norm", as_written=True)
    player.restore(os.path.join(DATA, "v165_layer_norm.pth"))
    assert getattr(player.policy, ckpt.NORMS_DROPPED)  # the model remembers, so the run's checkpoints say so
    for marked in (True, False):
        path = str(tmp_path / f"marked_{marked}.pth")
        state = {"format": ckpt.FORMAT, "model": player.policy.state_dict()}
        ckpt.save_atomic({**state, ckpt.NORMS_DROPPED: True} if marked else state, path)
        again = _player("v165", "layer_norm", as_written=True)
        if not marked:
            with pytest.raises(ckpt.CheckpointError, match="missing"):
                again.restore(path)
            continue
        caplog.clear()
        with caplog.at_level("WARNING", logger="rlchain"):
            again.restore(path)
        lines = [r.getMessage() for r in caplog.records if "1.6.5 builds no MLP normalization" in r.getMessage()]
        assert len(lines) == 1 and "this run continues one" in lines[0] and path in lines[0]
        assert not any(isinstance(m, torch.nn.LayerNorm) for m in again.policy.modules())
