"""``value_normalizer``: rl_games' value statistics fold the rollout's value predictions in with
the returns and clip at +-5, in and out; ``returns`` uses the returns only, unclipped (docs/ppo_parity.md,
"Hopper's first million frames", compares the two)."""

import gymnasium as gym
import pytest
import torch

from rlchain import Runner
from rlchain.builtins import actor_critic_model
from rlchain.config.errors import ConfigError
from rlchain.models.base import VALUE_NORM_CLIP, value_normalizer
from rlchain.models.central_value import CentralValue
from rlchain.networks.actor_critic import ActorCriticNetwork
from tests.conftest import BASE


def model(kind: str):
    """The BASE test config's params with normalize_value and this value_normalizer."""
    params = Runner().load({"params": {**BASE["params"], "config": {
        **BASE["params"]["config"], "normalize_value": True, "value_normalizer": kind}}}).params
    return params


def test_rl_games_statistics_are_those_of_the_values_and_the_returns_together():
    norm = value_normalizer(1, True, "rl_games")
    values = torch.tensor([[1.0], [2.0], [3.0]], dtype=torch.float64)
    returns = torch.tensor([[10.0], [20.0], [30.0], [40.0]], dtype=torch.float64)
    cv = CentralValue(None, (3,), 1, False, True, network=_Critic(), value_normalizer_kind="rl_games")
    cv.update_normalizers(returns=returns, values=values)
    both = torch.cat([values, returns])
    assert cv.value_mean_std.running_mean.item() == pytest.approx(both.mean().item(), rel=1e-4)  # count starts at 1e-5
    assert cv.value_mean_std.running_var.item() == pytest.approx(both.var(unbiased=False).item(), rel=1e-4)
    assert norm.clip == VALUE_NORM_CLIP == 5.0


def test_returns_statistics_ignore_the_values_and_do_not_clip():
    cv = CentralValue(None, (3,), 1, False, True, network=_Critic(), value_normalizer_kind="returns")
    returns = torch.tensor([[10.0], [20.0], [30.0], [40.0]], dtype=torch.float64)
    cv.update_normalizers(returns=returns, values=torch.zeros(3, 1, dtype=torch.float64))
    assert cv.value_mean_std.running_mean.item() == pytest.approx(25.0, rel=1e-4)
    assert cv.value_mean_std.clip == 0.0
    std = (cv.value_mean_std.running_var + cv.value_mean_std.epsilon).sqrt().item()
    assert cv.denorm_value(torch.tensor([[8.0]])).item() == pytest.approx(25.0 + 8.0 * std, rel=1e-5)


def test_rl_games_clamps_the_value_head_output_and_the_normalized_targets_at_5():
    cv = CentralValue(None, (3,), 1, False, True, network=_Critic(), value_normalizer_kind="rl_games")
    cv.update_normalizers(returns=torch.tensor([[10.0], [20.0], [30.0], [40.0]]), values=torch.tensor([[25.0]]))
    norm = cv.value_mean_std
    mean, std = norm.running_mean.item(), (norm.running_var + norm.epsilon).sqrt().item()
    assert cv.denorm_value(torch.tensor([[8.0], [-8.0], [1.0]])).flatten().tolist() == pytest.approx(
        [mean + 5 * std, mean - 5 * std, mean + std], rel=1e-5)  # the head's +-8 clamped to +-5 first
    assert cv.norm_value(torch.tensor([[mean + 9 * std]])).item() == pytest.approx(5.0)


def test_the_config_key_reaches_the_actor_critic_model():
    for kind, clip, fold in (("rl_games", 5.0, True), ("returns", 0.0, False)):
        params = model(kind)
        assert params.config.value_normalizer == kind
        net = ActorCriticNetwork(params.network, (3,), 2, 1, continuous=False)
        built = actor_critic_model(net, gym.spaces.Discrete(2), (3,), 1, params.config, "discrete_a2c")
        assert built.value_mean_std.clip == clip and built.fold_values is fold


def test_an_unknown_value_normalizer_is_a_one_line_config_error():
    with pytest.raises(ConfigError, match="value_normalizer") as err:
        model("rms")
    assert "\n" not in str(err.value) and "rl_games" in str(err.value)


class _Critic(torch.nn.Module):
    """A registered critic network stand-in: state -> value."""

    def __init__(self):
        super().__init__()
        self.value = torch.nn.Linear(3, 1)

    def forward(self, input_dict):
        return self.value(input_dict["obs"]), None

    def is_rnn(self):
        return False
