"""Through the face, a user's RLModule and a MultiAgentEnv's two policies learn (rlchain/rllib/module_network.py,
rlchain/rllib/multi_agent.py): a broken value / distribution wiring or masking stays far below the thresholds."""

import gymnasium as gym
import numpy as np
import pytest
import torch
from torch import nn

from rlchain.rllib.algorithms.appo import APPOConfig
from rlchain.rllib.algorithms.impala import IMPALAConfig
from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.core.columns import Columns
from rlchain.rllib.core.rl_module.apis import ValueFunctionAPI
from rlchain.rllib.core.rl_module.rl_module import RLModuleSpec
from rlchain.rllib.core.rl_module.torch import TorchRLModule
from rlchain.rllib.env.multi_agent_env import MultiAgentEnv


class SmallModule(TorchRLModule, ValueFunctionAPI):
    def setup(self):
        size, hidden = self.observation_space.shape[0], self.model_config["hidden"]
        self.pi = nn.Sequential(nn.Linear(size, hidden), nn.Tanh(), nn.Linear(hidden, self.action_space.n))
        self.vf = nn.Sequential(nn.Linear(size, hidden), nn.Tanh(), nn.Linear(hidden, 1))

    def _forward(self, batch, **kwargs):
        return {Columns.ACTION_DIST_INPUTS: self.pi(batch[Columns.OBS])}

    def compute_values(self, batch, embeddings=None):
        return self.vf(batch[Columns.OBS]).squeeze(-1)


class NameTheTarget(MultiAgentEnv):
    """Two agents each see a one-hot target of 3 and get +1 for naming it; 10 steps (random play: about 6.7 for
    the pair, perfect: 20)."""

    def __init__(self, config=None):
        super().__init__()
        self.agents = self.possible_agents = ["a", "b"]
        self.observation_spaces = {a: gym.spaces.Box(0.0, 1.0, (3,), np.float32) for a in self.agents}
        self.action_spaces = {a: gym.spaces.Discrete(3) for a in self.agents}
        self.rng = np.random.default_rng(0)

    def _obs(self):
        self.target = {a: int(self.rng.integers(3)) for a in self.agents}
        return {a: np.eye(3, dtype=np.float32)[self.target[a]] for a in self.agents}

    def reset(self, *, seed=None, options=None):
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.t = 0
        return self._obs(), {}

    def step(self, actions):
        rewards = {a: float(actions[a] == self.target[a]) for a in actions}
        self.t += 1
        return self._obs(), rewards, {"__all__": self.t >= 10}, {"__all__": False}, {}


@pytest.mark.slow
def test_a_users_module_learns_cartpole(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    torch.set_num_threads(1)
    config = (PPOConfig().environment("CartPole-v1").debugging(seed=1)
              .training(lr=1e-3, num_epochs=6, vf_loss_coeff=0.01)
              .rl_module(rl_module_spec=RLModuleSpec(module_class=SmallModule, model_config={"hidden": 32})))
    algo = config.build_algo()
    best = 0.0
    try:
        for _ in range(12):  # 48k env steps; random play scores about 22
            best = max(best, algo.train()["env_runners"]["episode_return_mean"])
            if best >= 150:
                break
    finally:
        algo.stop()
    assert best >= 150, f"best return {best:.1f}"


@pytest.mark.slow
def test_two_policies_learn_a_multi_agent_env(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    torch.set_num_threads(1)
    config = (PPOConfig().environment(NameTheTarget).env_runners(num_env_runners=1).debugging(seed=1)
              .training(train_batch_size=400, minibatch_size=100, num_epochs=4, lr=3e-3)
              .multi_agent(policies={"pa", "pb"}, policy_mapping_fn=lambda aid, *a, **kw: f"p{aid}"))
    algo = config.build_algo()
    try:
        for _ in range(15):
            result = algo.train()
    finally:
        algo.stop()
    modules = result["env_runners"]["module_episode_returns_mean"]
    assert result["env_runners"]["episode_return_mean"] >= 15.0, result["env_runners"]
    assert min(modules.values()) >= 7.0, modules  # each policy well above random's 3.3


@pytest.mark.slow
@pytest.mark.parametrize("cls", [APPOConfig, IMPALAConfig])
def test_two_policies_learn_a_multi_agent_env_under_vtrace(tmp_path, monkeypatch, cls):
    """rlchain's multi-policy appo / impala: each policy's V-trace learner."""
    monkeypatch.chdir(tmp_path)
    torch.set_num_threads(1)
    config = (cls().environment(NameTheTarget).env_runners(num_env_runners=0).debugging(seed=1)
              .training(train_batch_size=400, lr=3e-3, vf_loss_coeff=0.5, entropy_coeff=0.0)
              .multi_agent(policies={"pa", "pb"}, policy_mapping_fn=lambda aid, *a, **kw: f"p{aid}"))
    algo = config.build_algo()
    try:
        for _ in range(15):
            result = algo.train()
    finally:
        algo.stop()
    modules = result["env_runners"]["module_episode_returns_mean"]
    assert result["env_runners"]["episode_return_mean"] >= 15.0, result["env_runners"]
    assert min(modules.values()) >= 7.0, modules  # each policy well above random's 3.3
