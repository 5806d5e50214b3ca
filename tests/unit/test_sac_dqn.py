"""SAC and DQN models and updates: squashed Gaussian, deterministic play, targets, epsilon schedule."""

import math
import os

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.algos.off_policy.dqn_agent import DQNAgent, QModel, epsilon_at
from rlchain.algos.off_policy.sac_agent import SACAgent, SoftActorCritic
from rlchain.config import ConfigError, parse_params
from rlchain.config.load import load_raw
from rlchain.config.network import MlpConfig
from rlchain.config.off_policy import DQNConfig, DQNNetworkConfig, SACConfig, SACNetworkConfig
from rlchain.networks.sac_network import QNetwork, SACNetwork

CONFIGS = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir, "rlchain", "configs")
BOX = gym.spaces.Box(low=np.array([-2.0, 0.0], dtype=np.float32), high=np.array([2.0, 1.0], dtype=np.float32))


def sac_model(bounds=(-5.0, 2.0), **cfg):
    torch.manual_seed(0)
    net_cfg = SACNetworkConfig(mlp=MlpConfig(units=[16, 16], activation="relu"), log_std_bounds=list(bounds))
    net = SACNetwork(net_cfg, (3,), 2)
    config = SACConfig(env_name="x", batch_size=8, **cfg)
    return SoftActorCritic(net, BOX, (3,), False, config.init_alpha), config


def batch(n=8, obs_dim=3, act_dim=2, discrete=False):
    g = torch.Generator().manual_seed(1)
    actions = (torch.randint(0, act_dim, (n,), generator=g) if discrete
               else torch.rand(n, act_dim, generator=g) * 2 - 1)
    return {"obs": torch.randn(n, obs_dim, generator=g), "next_obs": torch.randn(n, obs_dim, generator=g),
            "actions": actions, "rewards": torch.randn(n, generator=g), "discounts": torch.full((n,), 0.99),
            "terminated": torch.tensor([True, False] * (n // 2)), "weights": torch.ones(n)}


def test_sac_deterministic_play_is_deterministic():
    model, _ = sac_model()
    obs = torch.randn(5, 3)
    a1 = model.act(obs, deterministic=True)["actions"]
    a2 = model.act(obs, deterministic=True)["actions"]
    assert torch.equal(a1, a2)
    mu, _ = model.network.actor(obs)
    assert torch.allclose(a1, torch.tanh(mu))
    s1 = model.act(obs, deterministic=False)["actions"]
    s2 = model.act(obs, deterministic=False)["actions"]
    assert not torch.equal(s1, s2)
    assert s1.abs().max() <= 1.0


def test_sac_log_prob_matches_tanh_transformed_normal():
    model, _ = sac_model()
    obs = torch.randn(64, 3)
    torch.manual_seed(3)
    actions, logp = model.policy(obs)
    mu, log_std = model.network.actor(obs)
    base = torch.distributions.Normal(mu, log_std.exp())
    u = torch.atanh(actions.clamp(-1 + 1e-6, 1 - 1e-6))
    ref = (base.log_prob(u) - torch.log(1 - torch.tanh(u).square())).sum(-1)
    mask = actions.abs().max(-1).values < 0.999  # atanh is ill-conditioned at the edges
    assert torch.allclose(logp[mask], ref[mask], atol=1e-3)


def test_sac_log_std_bounds_from_network_and_config():
    model, _ = sac_model(bounds=(-1.0, 0.5))
    _, log_std = model.network.actor(torch.randn(100, 3) * 100)
    assert log_std.min() >= -1.0 and log_std.max() <= 0.5
    net = SACNetwork(SACNetworkConfig(mlp=MlpConfig(units=[8])), (3,), 2)
    model2 = SoftActorCritic(net, BOX, (3,), False, 1.0, log_std_bounds=[-2.0, -1.0])
    _, log_std = model2.network.actor(torch.randn(100, 3) * 100)
    assert log_std.min() >= -2.0 and log_std.max() <= -1.0


def test_sac_mean_clip_clips_the_pre_tanh_mean():
    torch.manual_seed(0)
    net = SACNetwork(SACNetworkConfig(mlp=MlpConfig(units=[8]), mean_clip=0.5), (3,), 2)
    mu, _ = net.actor(torch.randn(100, 3) * 100)
    assert mu.abs().max().item() == pytest.approx(0.5)
    cfg = load_raw(os.path.join(CONFIGS, "sac_pendulum.yaml"))
    cfg["params"]["network"]["mean_clip"] = -1
    with pytest.raises(ConfigError) as err:
        parse_params(cfg, "sac.yaml")
    assert "sac.yaml" in str(err.value) and "params.network.mean_clip" in str(err.value)
    assert "must be a number > 0, or null for no clip" in str(err.value) and "\n" not in str(err.value)


def test_sac_actions_rescaled_to_space():
    model, _ = sac_model()
    out = model.dist.to_env(torch.tensor([[-1.0, -1.0], [1.0, 1.0], [0.0, 0.0]]))
    assert torch.allclose(out, torch.tensor([[-2.0, 0.0], [2.0, 1.0], [0.0, 0.5]]))


def test_sac_update_moves_targets_by_tau_and_alpha():
    model, cfg = sac_model(critic_tau=0.5, init_alpha=0.2)
    agent = SACAgent(model, cfg)
    before = [p.clone() for p in model.critic_target.parameters()]
    alpha0 = float(model.alpha.detach())
    stats, td = agent.update(batch())
    assert td.shape == (8,) and set(stats) >= {"critic_loss", "actor_loss", "alpha_loss", "entropy"}
    assert alpha0 == pytest.approx(0.2)
    for b, t, p in zip(before, model.critic_target.parameters(), model.network.critic.parameters()):
        assert torch.allclose(t, 0.5 * b + 0.5 * p, atol=1e-6)
    assert float(model.alpha.detach()) != alpha0  # learnable temperature stepped
    assert agent.target_entropy == -2.0


def test_sac_policy_frequency_and_fixed_temperature():
    model, cfg = sac_model(policy_frequency=2, learnable_temperature=False)
    agent = SACAgent(model, cfg)
    actor0 = [p.clone() for p in model.network.actor.parameters()]
    agent.update(batch())  # update 0: actor steps
    actor1 = [p.clone() for p in model.network.actor.parameters()]
    agent.update(batch())  # update 1: critic only
    assert any(not torch.equal(a, b) for a, b in zip(actor0, actor1))
    assert all(torch.equal(a, b) for a, b in zip(actor1, model.network.actor.parameters()))
    assert float(model.alpha.detach()) == pytest.approx(1.0)


def test_sac_critic_learns_fixed_targets():
    model, cfg = sac_model(critic_lr=1e-2)
    agent = SACAgent(model, cfg)
    b = batch(32)
    b["terminated"] = torch.ones(32, dtype=torch.bool)  # target = reward only
    first, _ = agent.update(b)
    for _ in range(200):
        stats, _ = agent.update(b)
    assert float(stats["critic_loss"]) < 0.1 * float(first["critic_loss"])


def q_model(dueling=True):
    torch.manual_seed(0)
    net = QNetwork(DQNNetworkConfig(mlp=MlpConfig(units=[16]), dueling=dueling), (3,), 4)
    return QModel(net, 4, (3,), False)


def test_dueling_head_mean_advantage_is_value():
    model = q_model(dueling=True)
    obs = torch.randn(6, 3)
    q = model.q_values(obs)
    h = model.network.trunk(obs)
    assert torch.allclose(q.mean(-1), model.network.state_value(h).squeeze(-1), atol=1e-6)


def test_dqn_head_gives_each_stream_its_own_layers():
    # RLlib's cartpole_dqn.py: fcnet_hiddens [256] then head_fcnet_hiddens [256] for the advantage and value heads
    torch.manual_seed(0)
    cfg = DQNNetworkConfig(mlp=MlpConfig(units=[16], activation="tanh"), dueling=True,
                           head=MlpConfig(units=[8], activation="relu"))
    net = QNetwork(cfg, (3,), 4)
    assert [m.out_features for m in net.advantage.modules() if isinstance(m, torch.nn.Linear)] == [8, 4]
    assert [m.out_features for m in net.state_value.modules() if isinstance(m, torch.nn.Linear)] == [8, 1]
    obs = torch.randn(5, 3)
    h = net.trunk(obs)
    assert torch.allclose(net(obs).mean(-1), net.state_value(h).squeeze(-1), atol=1e-6)
    plain = QNetwork(DQNNetworkConfig(mlp=MlpConfig(units=[16]), head=MlpConfig(units=[])), (3,), 4)
    assert isinstance(plain.advantage, torch.nn.Linear)  # no head layers: the linear layer as before


def test_dqn_greedy_is_deterministic_and_epsilon_explores():
    model = q_model()
    obs = torch.randn(200, 3)
    a1 = model.act(obs, deterministic=True)["actions"]
    assert torch.equal(a1, model.act(obs, deterministic=True)["actions"])
    assert torch.equal(a1, model.q_values(obs).argmax(-1))
    assert torch.equal(model.act(obs, epsilon=0.0)["actions"], a1)
    random = model.act(obs, epsilon=1.0)["actions"]
    assert (random != a1).float().mean() > 0.5


def test_double_dqn_target_hand_computed():
    model = q_model(dueling=False)
    cfg = DQNConfig(env_name="x", batch_size=2, learning_rate=1e-9, loss="mse", grad_norm=None)
    agent = DQNAgent(model, cfg)
    with torch.no_grad():
        for p in model.target.parameters():
            p.mul_(-1.0)  # make online and target disagree
    b = batch(2, discrete=True, act_dim=4)
    b["terminated"] = torch.tensor([False, True])
    online_next = model.network(b["next_obs"])
    target_next = model.target(b["next_obs"])
    chosen = online_next.argmax(-1)
    expected_target = b["rewards"] + b["discounts"] * torch.tensor([1.0, 0.0]) * target_next[
        torch.arange(2), chosen]
    q = model.network(b["obs"])[torch.arange(2), b["actions"]]
    _, td = agent.update(b)
    assert torch.allclose(td, (q - expected_target).abs().detach(), atol=1e-5)


def test_dqn_target_network_update_frequency():
    model = q_model()
    cfg = DQNConfig(env_name="x", batch_size=2, target_update_frequency=2, target_tau=1.0)
    agent = DQNAgent(model, cfg)
    b = batch(4, discrete=True, act_dim=4)
    agent.update(b)
    assert not all(torch.equal(a, b_) for a, b_ in zip(model.target.parameters(), model.network.parameters()))
    agent.update(b)
    assert all(torch.equal(a, b_) for a, b_ in zip(model.target.parameters(), model.network.parameters()))


def test_epsilon_schedule():
    assert epsilon_at(-5, 1.0, 0.1, 100) == 1.0
    assert epsilon_at(50, 1.0, 0.1, 100) == pytest.approx(0.55)
    assert epsilon_at(1000, 1.0, 0.1, 100) == pytest.approx(0.1)
    assert math.isfinite(epsilon_at(0, 1.0, 0.1, 1))


@pytest.mark.parametrize("frames,steps,expect", [(None, None, 1000), (None, 5, 5 * 4 * 2), (300, 5, 300)])
def test_warmup_frames_from_rl_games_num_warmup_steps(frames, steps, expect):
    cfg = SACConfig(env_name="Pendulum-v1", num_actors=4, num_steps_per_episode=2, num_warmup_frames=frames,
                    num_warmup_steps=steps)
    assert cfg.validate() is None
    assert cfg.num_warmup_frames == expect


def test_bad_num_warmup_steps_is_a_one_line_error():
    import os

    from rlchain import Runner
    from rlchain.config.errors import ConfigError
    from tests.conftest import CONFIGS

    with pytest.raises(ConfigError, match=r"sac_pendulum.yaml: params.config.num_warmup_steps: must be >= 0") as err:
        Runner().load(os.path.join(CONFIGS, "sac_pendulum.yaml"), ["params.config.num_warmup_steps=-1"])
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("override, says", [("params.network.head.units=abc", "head.units: expected a list"),
                                            ("params.network.head.unitz=[8]", "head.unitz: unknown key")])
def test_a_bad_dqn_head_block_is_a_one_line_error_naming_the_file_and_key(override, says):
    with pytest.raises(ConfigError, match=rf"dqn_cartpole.yaml: params.network.{says}") as err:
        Runner().load(os.path.join(CONFIGS, "dqn_cartpole.yaml"), [override])
    assert "\n" not in str(err.value)
