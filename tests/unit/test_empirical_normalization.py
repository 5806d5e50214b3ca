"""``obs_normalizer: rsl_rl``: rsl_rl's empirical normalization (rlchain/models/normalization.py), folded in at
every env step of the rollout (rlchain/algos/ppo/rollout.py)."""

import copy

import pytest
import torch

from rlchain.models.normalization import EmpiricalNormalization, RunningMeanStd, obs_normalizer
from tests.conftest import ppo_epochs


def rsl_rl_update(mean, var, count, x):
    """rsl_rl's update rule, written out: rate = n / (count + n), the mean moves by rate * delta and the
    variance by rate * (var_x - var + delta * (mean_x - new mean))."""
    n = x.shape[0]
    count = count + n
    rate = n / count
    mean_x, var_x = x.mean(0), x.var(0, unbiased=False)
    delta = mean_x - mean
    new_mean = mean + rate * delta
    return new_mean, var + rate * (var_x - var + delta * (mean_x - new_mean)), count


def test_statistics_match_rsl_rl_step_by_step_and_the_whole_batch():
    torch.manual_seed(0)
    steps = [torch.randn(16, 3, dtype=torch.float64) * torch.tensor([1.0, 5.0, 0.1]) + 2.0 for _ in range(6)]
    norm = EmpiricalNormalization((3,))
    mean, var, count = torch.zeros(3, dtype=torch.float64), torch.ones(3, dtype=torch.float64), 0
    for x in steps:
        norm.update(x)
        mean, var, count = rsl_rl_update(mean, var, count, x)
    torch.testing.assert_close(norm.running_mean, mean)
    torch.testing.assert_close(norm.running_var, var)
    everything = torch.cat(steps)
    torch.testing.assert_close(norm.running_mean, everything.mean(0))  # the first batch replaced the initial 0 / 1
    torch.testing.assert_close(norm.running_var, everything.var(0, unbiased=False))
    x = torch.randn(4, 3)
    expected = (x - mean.float()) / (var.float().sqrt() + 1e-2)  # no clip
    torch.testing.assert_close(norm.normalize(x), expected)
    torch.testing.assert_close(norm.denormalize(norm.normalize(x)), x, atol=1e-5, rtol=1e-5)


def test_the_factory_and_a_bad_kind():
    assert type(obs_normalizer((2,), "rl_games")) is RunningMeanStd
    assert isinstance(obs_normalizer((2,), "rsl_rl"), EmpiricalNormalization)
    with pytest.raises(ValueError, match="rl_games, rsl_rl"):
        obs_normalizer((2,), "rsl")


def test_rsl_rl_normalizer_folds_every_env_step_of_the_rollout(base_config):
    config = copy.deepcopy(base_config)
    config["params"]["config"].update(normalize_input=True, obs_normalizer="rsl_rl")
    _, ppo = ppo_epochs(config, [], 4, 2)
    norm = ppo.model.running_mean_std
    assert isinstance(norm, EmpiricalNormalization)
    assert int(norm.count) == 2 * 8 * 4  # epochs x horizon_length x envs: each step's next observations, once
    config["params"]["config"]["obs_normalizer_update"] = "rollout"
    _, ppo = ppo_epochs(config, [], 4, 2)
    assert int(ppo.model.running_mean_std.count) == 2 * 8 * 4  # the same rows, folded once per rollout
