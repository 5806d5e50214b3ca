"""rlchain checkpoints as rl_games' dicts (rlchain.runs.rl_games_checkpoint) for networks written the rl_games way, and
the keys a checkpoint under rl_games' API carries beside rlchain's (rlchain.runs.rl_games_layout.rl_games_keys)."""

import gymnasium as gym
import pytest
import torch

from rlchain.rl_games.algos_torch import model_builder, models, network_builder
from rlchain.runs import rl_games_checkpoint
from rlchain.runs.rl_games_layout import rl_games_keys

BLOCK = {"name": "own_a2c", "separate": False, "space": {"discrete": {}},
         "mlp": {"units": [8], "activation": "elu", "initializer": {"name": "default"}}}
BUILD = {"actions_num": 2, "input_shape": (4,), "value_size": 1, "num_seqs": 1}


class HeadBuilder(network_builder.A2CBuilder):
    class Network(network_builder.A2CBuilder.Network):  # A2CBuilder's network with one module of its own
        def __init__(self, params, **kwargs):
            super().__init__(params, **kwargs)
            self.extra = self._build_mlp(self.units[-1], [3], "None", torch.nn.Linear)

    def build(self, name, **kwargs):
        return HeadBuilder.Network(self.params, **kwargs)


def _ppo_state(network):
    """An rlchain PPO checkpoint of ``network`` (as rlchain's model holds it: ``a2c_network.*`` and the
    normalizers), with the optimizer state of one Adam step."""
    f64 = torch.float64
    model = {"value_mean_std.running_mean": torch.zeros(1, dtype=f64),
             "value_mean_std.running_var": torch.ones(1, dtype=f64),
             "value_mean_std.count": torch.tensor(3.0, dtype=f64),
             "running_mean_std.running_mean": torch.arange(4.0, dtype=f64),
             "running_mean_std.running_var": torch.ones(4, dtype=f64),
             "running_mean_std.count": torch.tensor(5.0, dtype=f64)}
    model.update({f"a2c_network.{k}": v for k, v in network.state_dict().items()})
    optimizer = torch.optim.Adam(network.parameters())
    sum(p.sum() for p in network.parameters()).backward()
    optimizer.step()
    return {"algo": "a2c_discrete", "config": {"params": {"network": dict(BLOCK)}}, "model": model,
            "agent": {"optimizer": optimizer.state_dict()}, "epoch": 7, "frames": 896, "best_reward": 12.5}


def test_an_own_a2c_network_is_written_in_rl_games_model_layout():
    builder = HeadBuilder()
    builder.load(BLOCK)
    state = _ppo_state(builder.build("a2c", **BUILD))
    out = rl_games_checkpoint.to_rl_games(state)
    # rl_games' model around the same builder takes the dict as it is, in its own order
    rl_model = models.ModelA2C(builder).build({**BUILD, "normalize_input": True, "normalize_value": True})
    assert list(out["model"]) == list(rl_model.state_dict())
    rl_model.load_state_dict(out["model"])
    assert torch.equal(rl_model.running_mean_std.running_mean, torch.arange(4.0, dtype=torch.float64))
    assert "a2c_network.extra.0.weight" in out["model"] and (out["epoch"], out["frame"]) == (7, 896)
    # the optimizer over rl_games' model.parameters(): one group, the same per-parameter state
    theirs = torch.optim.Adam(rl_model.parameters())
    theirs.load_state_dict(out["optimizer"])
    ours = state["agent"]["optimizer"]["state"]
    assert all(torch.equal(theirs.state_dict()["state"][i]["exp_avg"], ours[i]["exp_avg"]) for i in ours)
    assert out["last_mean_rewards"] == 12.5


def test_a_key_outside_the_network_and_normalizers_is_a_value_error():
    builder = HeadBuilder()
    builder.load(BLOCK)
    state = _ppo_state(builder.build("a2c", **BUILD))
    state["model"]["log_std"] = torch.zeros(2)
    with pytest.raises(ValueError, match="'log_std' is outside the network and its normalizers"):
        rl_games_checkpoint.to_rl_games(state)


def test_launcher_checkpoint_of_an_own_network_carries_rl_games_model(scoped_registries):
    builder = HeadBuilder()
    builder.load(BLOCK)
    state = _ppo_state(builder.build("a2c", **BUILD))
    model_builder.register_network("own_a2c", HeadBuilder)
    out = rl_games_keys(state)
    assert out["rlchain_model"] is state["model"] and list(out["model"])[-1] == "a2c_network.extra.0.bias"
    assert {"optimizer", "frame", "last_mean_rewards", "env_state"} <= set(out)


def test_a_network_not_registered_the_rl_games_way_gets_the_counters_only(scoped_registries):
    from rlchain import model_builder as rlchain_model_builder

    builder = HeadBuilder()
    builder.load(BLOCK)
    state = _ppo_state(builder.build("a2c", **BUILD))
    rlchain_model_builder.register_network("own_a2c", lambda params, **kwargs: None, overwrite=True)
    out = rl_games_keys(state)
    assert out["model"] is state["model"] and "rlchain_model" not in out and out["frame"] == 896


def test_an_own_sac_network_is_written_as_rl_games_sac_parts():
    builder = network_builder.SACBuilder()
    builder.load({"name": "own_sac", "separate": True, "log_std_bounds": [-5, 2],
                  "mlp": {"units": [8], "activation": "relu", "initializer": {"name": "default"}}})
    net = builder.build("sac", obs_dim=3, action_dim=1, input_shape=(3,), actions_num=1,
                        action_space=gym.spaces.Box(-1, 1, (1,)))
    target = {f"critic_target.{k}": v + 1.0 for k, v in net.critic.state_dict().items()}  # rlchain's trained target
    model = {**{f"network.{k}": v for k, v in net.state_dict().items()}, **target, "log_alpha": torch.tensor(0.5),
             "running_mean_std.running_mean": torch.zeros(3, dtype=torch.float64),
             "running_mean_std.running_var": torch.ones(3, dtype=torch.float64),
             "running_mean_std.count": torch.tensor(1.0, dtype=torch.float64)}
    out = rl_games_checkpoint.to_rl_games({"algo": "sac", "model": model, "epoch": 2, "frames": 100,
                                                   "agent": {"actor_opt": {"state": {}, "param_groups": []}}})
    net.actor.load_state_dict(out["actor"])
    net.critic.load_state_dict(out["critic"])
    net.critic_target.load_state_dict(out["critic_target"])  # rlchain's target, not the builder's own copy
    assert torch.equal(out["critic_target"]["Q1.0.bias"], model["critic_target.Q1.0.bias"])
    assert set(out["running_mean_std"]) == {"running_mean", "running_var", "count"}
    assert out["log_alpha"] == 0.5 and "actor_optimizer" in out and (out["epoch"], out["frame"]) == (2, 100)
