"""Normalizers, storage, registry and the built-in network."""

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import env_configurations
from rlchain.algos.core.storage import RolloutStorage
from rlchain.config.network import MlpConfig, NetworkConfig
from rlchain.models.normalization import RunningMeanStd
from rlchain.networks.actor_critic import ActorCriticBuilder
from rlchain.networks.mlp import MLP
from rlchain.registry import (
    ENVS,
    NETWORKS,
    VECENVS,
    WRITERS,
    Registry,
    RegistryError,
    scoped_registrations,
)


def test_running_mean_std_matches_numpy():
    rms = RunningMeanStd((3,), clip=0.0)
    data = np.random.default_rng(0).normal(2.0, 3.0, size=(1000, 3))
    for chunk in np.split(data, 10):
        rms.update(torch.as_tensor(chunk))
    assert np.allclose(rms.running_mean.numpy(), data.mean(0), atol=1e-6)
    assert np.allclose(rms.running_var.numpy(), data.var(0), atol=1e-4)
    x = torch.as_tensor(data[:5], dtype=torch.float32)
    assert torch.allclose(rms.denormalize(rms.normalize(x)), x, atol=1e-4)


def test_running_mean_std_clips():
    rms = RunningMeanStd((1,), clip=5.0)
    rms.update(torch.zeros(100, 1))
    assert rms.normalize(torch.tensor([[1e6]])).item() == pytest.approx(5.0)


def test_storage_shapes_and_misuse():
    s = RolloutStorage(4, 3, (2,), torch.float32, (), torch.long, 2, 1, torch.device("cpu"))
    with pytest.raises(RuntimeError, match="holds 0 of 4"):
        next(s.minibatches(4, torch.zeros(4, 3)))
    for t in range(4):
        s.add(t, torch.ones(3, 2) * t, torch.zeros(3, dtype=torch.long), torch.zeros(3), torch.zeros(3, 1),
              torch.zeros(3, 2))
    with pytest.raises(IndexError):
        s.add(4, torch.ones(3, 2), torch.zeros(3, dtype=torch.long), torch.zeros(3), torch.zeros(3, 1),
              torch.zeros(3, 2))
    batches = list(s.minibatches(4, torch.zeros(4, 3)))
    assert len(batches) == 3 and batches[0].obs.shape == (4, 2)
    seen = torch.cat([b.obs[:, 0] for b in batches]).sort().values
    assert seen.tolist() == sorted([float(t) for t in range(4) for _ in range(3)])


def test_registry_did_you_mean():
    r = Registry("thing")
    r.register("alpha", 1)
    with pytest.raises(RegistryError, match="did you mean 'alpha'"):
        r.get("alpah")
    with pytest.raises(ValueError, match="already registered"):
        r.register("alpha", 2)


def test_registry_scoped_undoes_registrations_replacements_and_removals():
    r = Registry("thing")
    r.register("alpha", 1)
    r.register("example", 2, replaceable=True)
    table = r._items
    with pytest.raises(RuntimeError), r.scoped():
        r.register("beta", 3)
        r.register("example", 4)  # a replaceable built-in replaced: no longer replaceable inside
        r.unregister("alpha")
        assert r.names() == ["beta", "example"]
        raise RuntimeError("the test failed")
    assert r.names() == ["alpha", "example"] and r.get("example") == 2 and r._items is table
    r.register("example", 5)  # replaceable again after the block
    with pytest.raises(RegistryError, match="unknown thing 'alpah'; did you mean 'alpha'"):
        r.unregister("alpah")


def test_scoped_registrations_restores_every_table():
    before = (NETWORKS.names(), VECENVS.names(), WRITERS.names(), ENVS.names())
    with scoped_registrations():
        NETWORKS.register("scoped_net", object)
        VECENVS.register("scoped_vec", object)
        WRITERS.unregister(WRITERS.names()[0])
        env_configurations.register("scoped_env", {"vecenv_type": "scoped_vec"})
    assert (NETWORKS.names(), VECENVS.names(), WRITERS.names(), ENVS.names()) == before


def test_mlp_d2rl_shapes():
    net = MLP(5, MlpConfig(units=[8, 4], d2rl=True))
    assert net(torch.zeros(2, 5)).shape == (2, 4)


def test_actor_critic_network_outputs():
    builder = ActorCriticBuilder()
    from rlchain.config.network import ContinuousSpaceConfig, SpaceConfig
    cfg = NetworkConfig(space=SpaceConfig(continuous=ContinuousSpaceConfig()))
    builder.load(cfg)
    net = builder.build("n", action_space=gym.spaces.Box(-1, 1, (3,)), input_shape=(4,), actions_num=3,
                        value_size=1)
    mu, sigma, value, states = net({"obs": torch.zeros(2, 4)})
    assert mu.shape == (2, 3) and sigma.shape == (2, 3) and value.shape == (2, 1) and states is None
    assert torch.allclose(sigma, torch.zeros(2, 3))  # const_initializer val 0 -> log-std 0
