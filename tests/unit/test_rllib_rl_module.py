"""Users' RLModule subclasses through the face (rlchain/rllib/module_network.py): written as RLlib's docs show
(setup, _forward / _forward_train, compute_values, self.model_config), passed with rl_module(rl_module_spec=...),
trained by rlchain's PPO; RLlib's action-masking pattern (a Dict observation with an action_mask) included."""

import re

import gymnasium as gym
import numpy as np
import pytest
import torch
from torch import nn

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule
from rlchain.rllib.core.columns import Columns
from rlchain.rllib.core.rl_module.apis import ValueFunctionAPI
from rlchain.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
from rlchain.rllib.core.rl_module.rl_module import RLModule, RLModuleSpec
from rlchain.rllib.core.rl_module.torch import TorchRLModule


class TwoHeads(TorchRLModule, ValueFunctionAPI):
    """A policy MLP and a value MLP, sizes from model_config."""

    def setup(self):
        hidden = self.model_config.get("hidden", 16)
        size = self.observation_space.shape[0]
        out = self.action_space.n if isinstance(self.action_space, gym.spaces.Discrete) \
            else 2 * self.action_space.shape[0]
        self.pi = nn.Sequential(nn.Linear(size, hidden), nn.Tanh(), nn.Linear(hidden, out))
        self.vf = nn.Sequential(nn.Linear(size, hidden), nn.Tanh(), nn.Linear(hidden, 1))
        self.calls = {"train": 0, "exploration": 0}

    def _forward_exploration(self, batch, **kwargs):
        self.calls["exploration"] += 1
        return self._forward(batch)

    def _forward_train(self, batch, **kwargs):
        self.calls["train"] += 1
        return self._forward(batch)

    def _forward(self, batch, **kwargs):
        return {Columns.ACTION_DIST_INPUTS: self.pi(batch[Columns.OBS])}

    def compute_values(self, batch, embeddings=None):
        return self.vf(batch[Columns.OBS]).squeeze(-1)


class MaskedChoice(gym.Env):
    """Dict observations {'action_mask', 'observations'}: a random half of 6 actions is allowed each step (an
    invalid action raises, as RLlib's ActionMaskEnv does); the highest allowed action pays 1."""

    def __init__(self, config=None):
        self.observation_space = gym.spaces.Dict({"action_mask": gym.spaces.Box(0.0, 1.0, (6,), np.float32),
                                                  "observations": gym.spaces.Box(-1.0, 1.0, (6,), np.float32)})
        self.action_space = gym.spaces.Discrete(6)
        self.rng = np.random.default_rng(0)

    def _obs(self):
        self.mask = np.zeros(6, np.float32)
        self.mask[self.rng.choice(6, 3, replace=False)] = 1.0
        return {"action_mask": self.mask, "observations": self.mask * 2 - 1}

    def reset(self, *, seed=None, options=None):
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.t = 0
        return self._obs(), {}

    def step(self, action):
        if not self.mask[action]:
            raise ValueError(f"invalid action {action} under mask {self.mask}")
        reward = float(action == int(np.flatnonzero(self.mask)[-1]))
        self.t += 1
        return self._obs(), reward, False, self.t >= 10, {}


class Masking(DefaultPPOTorchRLModule):
    """RLlib's action-masking pattern: the default PPO module on the 'observations' part, the logits of
    disallowed actions pushed to the float minimum."""

    def __init__(self, *, observation_space=None, **kwargs):
        self.space_with_mask = observation_space
        super().__init__(observation_space=observation_space["observations"], **kwargs)

    def setup(self):
        super().setup()
        self.observation_space = self.space_with_mask

    def _split(self, batch):
        mask = batch[Columns.OBS].pop("action_mask")
        batch[Columns.OBS] = batch[Columns.OBS].pop("observations")
        return mask, batch

    def _masked(self, out, mask):
        out[Columns.ACTION_DIST_INPUTS] = out[Columns.ACTION_DIST_INPUTS] + torch.clamp(torch.log(mask), min=-3.4e38)
        return out

    def _forward_inference(self, batch, **kwargs):
        mask, batch = self._split(batch)
        return self._masked(super()._forward_inference(batch), mask)

    def _forward_exploration(self, batch, **kwargs):
        mask, batch = self._split(batch)
        return self._masked(super()._forward_exploration(batch), mask)

    def _forward_train(self, batch, **kwargs):
        return self._masked(super()._forward_train(batch), batch["action_mask"])

    def compute_values(self, batch, embeddings=None):
        if isinstance(batch[Columns.OBS], dict):
            mask, batch = self._split(batch)
            batch["action_mask"] = mask
        return super().compute_values(batch, embeddings)


def test_rl_module_dispatches_as_rllibs_and_builds_from_its_spec():
    spec = RLModuleSpec(module_class=TwoHeads, observation_space=gym.spaces.Box(-1, 1, (3,)),
                        action_space=gym.spaces.Discrete(4), model_config={"hidden": 5})
    module = spec.build()
    assert module.pi[0].out_features == 5 and module.model_config == {"hidden": 5}
    out = module.forward_inference({"obs": torch.zeros(2, 3)})
    assert out[Columns.ACTION_DIST_INPUTS].shape == (2, 4)
    module.forward_train({"obs": torch.zeros(2, 3)})
    assert module.calls == {"train": 1, "exploration": 0}
    assert not module.is_stateful() and set(module.get_state()) == set(module.state_dict())

    class NoForward(RLModule):
        pass

    with pytest.raises(NotImplementedError, match="override _forward"):
        NoForward(observation_space=spec.observation_space, action_space=spec.action_space).forward_inference({})


def test_a_users_module_trains_under_ppo_and_restores(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = (PPOConfig().environment("CartPole-v1").env_runners(num_env_runners=1).debugging(seed=0)
              .training(train_batch_size=128, minibatch_size=64, num_epochs=2)
              .rl_module(rl_module_spec=RLModuleSpec(module_class=TwoHeads, model_config={"hidden": 8})))
    algo = config.build_algo()
    try:
        network = algo._stepper.context.model.a2c_network
        assert network.module.pi[0].out_features == 8
        before = [p.detach().clone() for p in network.module.parameters()]
        result = algo.train()
        assert network.module.calls["exploration"] >= 128 and network.module.calls["train"] >= 4
        assert any(not torch.equal(a, b) for a, b in zip(before, network.module.parameters()))
        assert np.isfinite(result["learners"]["default_policy"]["vf_loss"])
        obs = torch.ones(1, 4)
        logits = algo.get_module().forward_inference({"obs": obs})["action_dist_inputs"]
        assert torch.allclose(logits, network.module.pi(obs))
        path = algo.save_to_path(str(tmp_path / "ckpt"))
    finally:
        algo.stop()
    from rlchain.rllib.algorithms.algorithm import Algorithm

    with pytest.raises(ConfigError, match="trained an RLModule class.*restore_from_path") as info:
        Algorithm.from_checkpoint(path)
    assert "\n" not in str(info.value)
    with pytest.raises(ConfigError, match="trained an RLModule class.*restore_from_path"):
        RLModule.from_checkpoint(f"{path}/learner_group/learner/rl_module/default_policy")
    again = Algorithm.from_checkpoint(path, config=config)  # RLlib's way to pass what the JSON cannot hold
    try:
        assert torch.allclose(again.get_module().forward_inference({"obs": obs})["action_dist_inputs"], logits)
    finally:
        again.stop()


def test_continuous_actions_read_means_then_log_stds(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = (PPOConfig().environment("Pendulum-v1").env_runners(num_env_runners=1)
              .training(train_batch_size=64, minibatch_size=32, num_epochs=1)
              .rl_module(rl_module_spec=RLModuleSpec(module_class=TwoHeads)))
    algo = config.build_algo()
    try:
        algo.train()
        module = algo._stepper.context.model.a2c_network.module
        obs = torch.zeros(2, 3)
        out = algo.get_module().forward_inference({"obs": obs})["action_dist_inputs"]
        assert torch.allclose(out, module.pi(obs), atol=1e-6)  # rlchain's std is exp(log-std): the same layout
    finally:
        algo.stop()


def test_a_spec_with_only_model_config_is_rllibs_default_module(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = (PPOConfig().environment("CartPole-v1").env_runners(num_env_runners=1)
              .training(train_batch_size=64, minibatch_size=32, num_epochs=1)
              .rl_module(rl_module_spec=RLModuleSpec(model_config={"fcnet_hiddens": [12], "head_fcnet_hiddens": [7],
                                                                   "vf_share_layers": True})))
    algo = config.build_algo()
    try:
        module = algo._stepper.context.model.a2c_network.module
        assert isinstance(module, DefaultPPOTorchRLModule) and not hasattr(module.encoder, "critic_encoder")
        assert module.pi[0].in_features == 12 and module.pi[0].out_features == 7
        algo.train()
    finally:
        algo.stop()


def test_rllibs_action_masking_pattern_trains_without_an_invalid_action(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = (PPOConfig().environment(MaskedChoice).env_runners(num_env_runners=2).debugging(seed=0)
              .training(train_batch_size=200, minibatch_size=50, num_epochs=2)
              .rl_module(rl_module_spec=RLModuleSpec(module_class=Masking,
                                                     model_config={"fcnet_hiddens": [16], "head_fcnet_hiddens": [8]})))
    algo = config.build_algo()
    try:
        for _ in range(2):  # an invalid action would raise in the env and end the run
            result = algo.train()
        assert result["num_env_steps_sampled_lifetime"] == 400
        assert algo.evaluate()["env_runners"]["num_episodes"] == 10
        mask = torch.tensor([[0.0, 1, 0, 0, 1, 0]])
        out = algo.get_module().forward_inference({"obs": {"action_mask": mask, "observations": mask * 2 - 1}})
        assert out["action_dist_inputs"][0, 0] < -1e30 and out["action_dist_inputs"][0, 1] > -1e30
        one = {"action_mask": mask[0].numpy(), "observations": mask[0].numpy() * 2 - 1}
        assert algo.compute_single_action(one, explore=True) in (1, 4)
    finally:
        algo.stop()


def test_bad_modules_end_in_one_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)

    class NoValues(TorchRLModule):
        def setup(self):
            self.pi = nn.Linear(4, 2)

        def _forward(self, batch, **kwargs):
            return {Columns.ACTION_DIST_INPUTS: self.pi(batch[Columns.OBS])}

    class Recurrent(TwoHeads):
        def get_initial_state(self):
            return {"h": torch.zeros(8)}

    # each names the user's config and the rl_module_spec they gave (not the face's rlchain dict: "<dict>")
    where = "^" + re.escape("PPOConfig.rl_module(): rl_module_spec") + r"[\w.]*: "
    for spec, message in ((RLModuleSpec(module_class=NoValues), "NoValues has no compute_values: PPO needs"),
                          (RLModuleSpec(module_class=Recurrent), "Recurrent is stateful .get_initial_state.: "
                                                                 "recurrent RLModules are not trained"),
                          (RLModuleSpec(module_class=object), ".*expected a TorchRLModule subclass"),
                          ("TwoHeads", "expected an RLModuleSpec")):
        config = PPOConfig().environment("CartPole-v1").rl_module(rl_module_spec=spec)
        with pytest.raises(ConfigError, match=where + message) as info:
            config.build_algo()
        assert "\n" not in str(info.value) and "<dict>" not in str(info.value)
    assert MultiRLModuleSpec(rl_module_specs={"a": RLModuleSpec()}).spec_of("b") is None
