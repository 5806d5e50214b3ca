"""Auxiliary losses (a network's ``get_aux_loss()``): checked, added to the PPO loss, logged as
``losses/<name>``; rl_games' test networks ``testnet`` / ``testnet_aux_loss`` that use them."""

import copy

import gymnasium as gym
import numpy as np
import pytest
import torch
import torch.nn as nn

from rlchain.algos.core.losses import aux_loss_terms
from rlchain.algos.core.storage import RolloutStorage
from rlchain.algos.ppo.agent import PPOAgent
from rlchain.config.load import parse_params
from rlchain.errors import NetworkError
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import make_distribution
from rlchain.networks.example_networks import TestNet, TestNetAuxLoss
from rlchain.registry import NETWORKS, Registry
from rlchain.runs.logging import TrainLogger
from tests.conftest import BASE


class AuxNet(nn.Module):
    """Logits and value from the obs; ``aux_weight`` is used by the auxiliary loss only."""

    def __init__(self, aux=lambda net: {"aux_l2": net.aux_weight.square()}):
        super().__init__()
        self.body = nn.Linear(3, 2 + 1)
        self.aux_weight = nn.Parameter(torch.tensor(2.0))
        self.aux = aux

    def forward(self, input_dict):
        out = self.body(input_dict["obs"])
        return out[:, :2], out[:, 2:], None

    def get_aux_loss(self):
        return self.aux(self)


class PlainNet(AuxNet):
    get_aux_loss = None  # a network without the hook


def _agent(network, **config):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update({"num_actors": 2, "horizon_length": 4, "minibatch_size": 4, "mini_epochs": 2,
                                    "learning_rate": 1e-2, **config})
    cfg = parse_params(raw, "cfg.yaml").config
    model = ActorCritic(network, make_distribution("discrete_a2c", gym.spaces.Discrete(2), False), (3,), 1,
                        False, False)
    return PPOAgent(model, cfg, torch.device("cpu"))


def _rollout(model, horizon=4, envs=2):
    storage = RolloutStorage(horizon, envs, (3,), torch.float32, (), torch.long, 2, 1, torch.device("cpu"))
    gen = torch.Generator().manual_seed(0)
    for t in range(horizon):
        obs = torch.randn(envs, 3, generator=gen)
        out = model.act(obs)
        storage.add(t, obs, out["actions"], out["log_probs"], out["values"], out["params"])
        storage.add_outcome(t, torch.ones(envs, 1), torch.zeros(envs, dtype=torch.bool),
                            torch.zeros(envs, dtype=torch.bool))
    storage.advantages.copy_(torch.randn(horizon, envs, 1, generator=gen))
    storage.returns.copy_(torch.randn(horizon, envs, 1, generator=gen))
    return storage


def test_aux_loss_is_added_to_the_loss_and_returned_for_logging():
    agent = _agent(AuxNet())
    before = agent.model.a2c_network.aux_weight.item()
    stats = agent.update(_rollout(agent.model), progress=0.0)
    after = agent.model.a2c_network.aux_weight.item()
    assert after < before  # the gradient reached a parameter only the auxiliary loss uses
    assert stats["losses/aux_l2"] == pytest.approx(np.mean([before ** 2, after ** 2]), rel=0.2)


def test_network_without_aux_loss_has_no_aux_stats():
    agent = _agent(PlainNet())
    stats = agent.update(_rollout(agent.model), progress=0.0)
    assert agent.model.a2c_network.aux_weight.item() == 2.0  # untouched: no gradient
    assert not [key for key in stats if key.startswith("losses/")]


def test_aux_losses_average_over_the_minibatches_that_returned_them():
    calls = []

    def sometimes(net):  # a loss only on every other forward pass (None entries are skipped)
        calls.append(1)
        return {"aux_l2": net.aux_weight.square() if len(calls) % 2 else None}

    agent = _agent(AuxNet(aux=sometimes))
    stats = agent.update(_rollout(agent.model), progress=0.0)
    assert 3.0 < stats["losses/aux_l2"] < 4.5  # ~aux_weight ** 2 (about 4), not half of it


def test_aux_losses_are_logged_with_rl_games_tag_names():
    from rlchain.runs.writers import Writer

    written = {}

    class Recorder(Writer):
        def write(self, scalars, step):
            written.update(scalars)

    logger = TrainLogger(None, print_stats=False, writers=[Recorder()])
    stats = {"a_loss": 0.1, "c_loss": 0.2, "entropy": 0.3, "b_loss": 0.0, "lr": 1e-3, "kl": 0.01,
             "clip_frac": 0.0, "grad_norm": 1.0, "losses/aux_dist_loss": 0.5}
    from rlchain.algos.ppo.ppo import PPO
    from rlchain.training.loop import tag_metrics

    metrics = tag_metrics(stats, PPO.metric_tags)
    logger.epoch(1, 2, 64, metrics, None, float("-inf"), {"batch": 64, "rollout": 1.0, "update": 1.0})
    assert written["losses/aux_dist_loss"] == 0.5 and written["losses/a_loss"] == 0.1


def test_aux_loss_under_autocast_is_float32_and_backpropagates():
    net = TestNetAuxLoss({}, actions_num=4, observation_space=_test_env_space(aux=True))
    obs = torch.rand(5, 7)
    device = "cuda" if torch.cuda.is_available() else "cpu"
    net, obs = net.to(device), obs.to(device)
    dtype = torch.float16 if device == "cuda" else torch.bfloat16
    with torch.autocast(device, dtype=dtype):
        net({"obs": obs})
        (loss,) = aux_loss_terms(net.get_aux_loss()).values()
    loss.backward()
    assert loss.dtype == torch.float32 and net.aux_loss_linear.weight.grad is not None


@pytest.mark.parametrize("raw, fragment", [
    ({"aux": torch.ones(4)}, "get_aux_loss()['aux'] must be a scalar tensor, got shape (4,)"),
    ({"aux": 0.5}, "get_aux_loss()['aux'] must be a scalar tensor, got float"),
    ({"aux": torch.tensor(3)}, "get_aux_loss()['aux'] must be a floating-point tensor"),
    ({"a_loss": torch.tensor(1.0)}, "get_aux_loss()['a_loss']: the name collides with PPO's own losses/a_loss"),
    ([torch.tensor(1.0)], "get_aux_loss() must return a dict of scalar tensors or None, got list"),
])
def test_bad_aux_losses_raise_one_line_naming_the_key(raw, fragment):
    with pytest.raises(NetworkError) as info:
        aux_loss_terms(raw)
    assert fragment in str(info.value) and "\n" not in str(info.value)


def test_bad_aux_loss_stops_the_update_with_the_key_named():
    agent = _agent(AuxNet(aux=lambda net: {"per_sample": net.aux_weight * torch.ones(3)}))
    with pytest.raises(NetworkError, match=r"get_aux_loss\(\)\['per_sample'\] must be a scalar tensor"):
        agent.update(_rollout(agent.model), progress=0.0)


def test_aux_loss_terms_accepts_none_and_one_element_tensors():
    assert aux_loss_terms(None) == {}
    assert aux_loss_terms({"x": None}) == {}
    assert aux_loss_terms({"x": torch.ones(1, 1)})["x"].shape == ()


# ----- rl_games' test networks ---------------------------------------------------------------
def _test_env_space(aux=False):
    """TestRnnEnv-v0's Dict observation space with multi_obs_space (gymnasium sorts the keys)."""
    spaces = {"pos": gym.spaces.Box(-9, 9, (2,), np.float32), "info": gym.spaces.Box(-9, 9, (4,), np.float32)}
    if aux:
        spaces["aux_target"] = gym.spaces.Box(0, np.inf, (1,), np.float32)
    return gym.spaces.Dict(spaces)


def test_testnet_reads_pos_and_info_and_returns_rl_games_tuples():
    space = _test_env_space(aux=True)  # flat order: aux_target (1), info (4), pos (2)
    net = TestNet({"name": "testnet"}, actions_num=4, observation_space=space, value_size=2)
    obs = torch.randn(5, 7)
    logits, value, states = net({"obs": obs})
    assert logits.shape == (5, 4) and value.shape == (5, 2) and states is None
    moved = obs.clone()
    moved[:, 0] += 10.0  # aux_target: not an input of testnet
    assert torch.equal(net({"obs": moved})[0], logits)
    critic = TestNet({"name": "testnet", "central_value": True}, actions_num=1, observation_space=space)
    value, states = critic({"obs": obs})
    assert value.shape == (5, 1) and states is None


def test_testnet_aux_loss_learns_the_target_through_get_aux_loss():
    space = _test_env_space(aux=True)  # flat order: aux_target (1), info (4), pos (2)
    torch.manual_seed(0)
    net = TestNetAuxLoss({}, actions_num=4, observation_space=space)
    assert aux_loss_terms(net.get_aux_loss()) == {}  # no forward pass yet
    opt = torch.optim.Adam(net.parameters(), lr=3e-3)
    obs = torch.rand(256, 7) * 2 - 1
    obs[:, 0] = obs[:, 5:].square().sum(-1)  # the target: squared distance, as TestRnnEnv-v0 gives it
    losses = []
    for _ in range(60):
        net({"obs": obs})
        loss = aux_loss_terms(net.get_aux_loss())["aux_dist_loss"]
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(loss.item())
    assert losses[-1] < losses[0] / 5
    with torch.no_grad():
        net({"obs": obs})
        expected = torch.nn.functional.mse_loss(net.aux_loss_linear(net.features(obs)), obs[:, :1])
    assert net.aux_dist_loss.item() == pytest.approx(expected.item())


@pytest.mark.parametrize("space, fragment", [
    (gym.spaces.Box(-1, 1, (6,), np.float32), "params.network: testnet_aux_loss reads Dict observations with "
                                               "keys pos, info, aux_target"),
    (_test_env_space(aux=False), "multi_obs_space: True, aux_loss: True"),
])
def test_testnet_on_other_observations_is_a_one_line_error(space, fragment):
    with pytest.raises(ValueError) as info:
        TestNetAuxLoss({"name": "testnet_aux_loss"}, actions_num=4, observation_space=space)
    assert fragment in str(info.value) and "\n" not in str(info.value)


def test_testnet_rejects_continuous_actions():
    with pytest.raises(ValueError, match="params.network.name: testnet has a categorical head"):
        TestNet({"name": "testnet"}, actions_num=2, observation_space=_test_env_space(),
                action_space=gym.spaces.Box(-1, 1, (2,)))


def test_test_networks_are_registered_and_user_code_may_replace_them():
    assert "testnet" in NETWORKS and "testnet_aux_loss" in NETWORKS
    registry = Registry("network")
    registry.register("testnet", TestNet, overwrite=True, replaceable=True)
    registry.register("testnet", PlainNet)  # a user package's own testnet, as in rl_games
    assert registry.get("testnet") is PlainNet
    with pytest.raises(ValueError, match="already registered"):
        registry.register("testnet", AuxNet)  # the user's registration is not replaceable
