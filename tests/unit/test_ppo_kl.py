"""Which two policies the adaptive learning rate's KL compares (``kl_reference``), with hand-checkable numbers.

The rollout stored a Gaussian policy whose mean is 1 away from the current one in each of 2 action
dimensions (std 1 both): KL = 2 * 1^2 / 2 = 1.0 per sample. The learning rate is far too small to
move the policy, so the current policy stays where it is for the whole update.
"""

import copy

import gymnasium as gym
import pytest
import torch
import torch.nn as nn

from rlchain.algos.core.storage import RolloutStorage
from rlchain.algos.ppo.agent import PPOAgent
from rlchain.config import ConfigError
from rlchain.config.load import parse_params
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import make_distribution
from tests.conftest import BASE

HORIZON, ENVS, ACTIONS = 4, 2, 2


class GaussNet(nn.Module):
    """mu = W obs (W starts at zero), log-std 0, value = v . obs."""

    def __init__(self):
        super().__init__()
        self.mu = nn.Linear(3, ACTIONS, bias=False)
        nn.init.zeros_(self.mu.weight)
        self.logstd = nn.Parameter(torch.zeros(ACTIONS))
        self.value = nn.Linear(3, 1)

    def forward(self, input_dict):
        obs = input_dict["obs"]
        return self.mu(obs), self.logstd.expand(obs.shape[0], ACTIONS), self.value(obs), None


def _agent(model_name="continuous_a2c_logstd", space=None, network=None, **config):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update({"num_actors": ENVS, "horizon_length": HORIZON, "minibatch_size": 4,
                                    "mini_epochs": 2, "learning_rate": 1e-10, "lr_schedule": "adaptive",
                                    "kl_threshold": 0.008, "min_lr": 1e-14, **config})
    cfg = parse_params(raw, "cfg.yaml").config
    space = space or gym.spaces.Box(-1.0, 1.0, (ACTIONS,))
    model = ActorCritic(network or GaussNet(), make_distribution(model_name, space, False), (3,), 1, False, False)
    return PPOAgent(model, cfg, torch.device("cpu"))


def _rollout_one_away(agent):
    """A rollout whose stored policy has mean +1 (std 1) where the current policy has mean 0."""
    storage = RolloutStorage(HORIZON, ENVS, (3,), torch.float32, (ACTIONS,), torch.float32, 2 * ACTIONS, 1,
                             torch.device("cpu"))
    gen = torch.Generator().manual_seed(0)
    stored = torch.cat([torch.ones(ENVS, ACTIONS), torch.ones(ENVS, ACTIONS)], -1)  # mu 1, std 1
    for t in range(HORIZON):
        obs = torch.randn(ENVS, 3, generator=gen)
        actions = torch.randn(ENVS, ACTIONS, generator=gen)
        log_probs = agent.model.dist.log_prob(stored, actions)
        storage.add(t, obs, actions, log_probs, torch.zeros(ENVS, 1), stored)
        storage.add_outcome(t, torch.ones(ENVS, 1), torch.zeros(ENVS, dtype=torch.bool),
                            torch.zeros(ENVS, dtype=torch.bool))
    storage.advantages.copy_(torch.randn(HORIZON, ENVS, 1, generator=gen))
    storage.returns.copy_(torch.randn(HORIZON, ENVS, 1, generator=gen))
    return storage


def test_rollout_reference_measures_every_step_against_the_rollout_policy():
    agent = _agent(kl_reference="rollout")
    out = agent.update(_rollout_one_away(agent), progress=0.0)
    # 2 mini-epochs x 2 minibatches, each KL 1.0 > 2 * 0.008: the lr is divided by 1.5 four times
    assert out["kl"] == pytest.approx(1.0, rel=1e-5)
    assert out["lr"] == pytest.approx(1e-10 / 1.5 ** 4)


def test_previous_reference_measures_the_move_since_each_samples_previous_minibatch():
    agent = _agent(kl_reference="previous")
    out = agent.update(_rollout_one_away(agent), progress=0.0)
    # first pass: both minibatches against the rollout (1.0 each: the reference is per sample, so the
    # second minibatch is not compared with what the first one wrote); second pass: against the policy
    # of the first pass, which did not move (0). Mean (1 + 1 + 0 + 0) / 4 = 0.5; lr / 1.5^2 * 1.5^2.
    assert out["kl"] == pytest.approx(0.5, rel=1e-5)
    assert out["lr"] == pytest.approx(1e-10)


def test_auto_reference_is_previous_for_continuous_and_rollout_for_discrete():
    agent = _agent()
    assert agent.cfg.kl_reference == "auto"
    assert agent.update(_rollout_one_away(agent), progress=0.0)["kl"] == pytest.approx(0.5, rel=1e-5)
    discrete = _agent("discrete_a2c", gym.spaces.Discrete(2), nn.Linear(3, 3))
    assert discrete._kl_reference(_rollout_one_away(agent)) is None


def test_previous_reference_with_standard_schedule_averages_each_mini_epoch():
    agent = _agent(kl_reference="previous", schedule_type="standard")
    out = agent.update(_rollout_one_away(agent), progress=0.0)
    # mini-epoch means 1.0 (lr / 1.5) then 0.0 (lr * 1.5)
    assert out["kl"] == pytest.approx(0.5, rel=1e-5) and out["lr"] == pytest.approx(1e-10)


def test_bad_kl_reference_is_a_one_line_config_error():
    raw = copy.deepcopy(BASE)
    raw["params"]["config"]["kl_reference"] = "previus"
    with pytest.raises(ConfigError, match=r"cfg.yaml.*params.config.kl_reference.*previous") as info:
        parse_params(raw, "cfg.yaml")
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("rnn", [False, True])
def test_minibatch_index_names_each_rows_place_in_the_rollout(rnn):
    storage = RolloutStorage(4, 3, (1,), torch.float32, (), torch.long, 2, 1, torch.device("cpu"),
                             state_shapes=((1, 3, 2),) if rnn else ())
    storage.obs.copy_(torch.arange(12.0).reshape(4, 3, 1))
    storage.filled = 4
    batches = (storage.sequence_minibatches(4, 2, torch.zeros(4, 3)) if rnn
               else storage.minibatches(4, torch.zeros(4, 3)))
    seen = []
    for batch in batches:
        assert torch.equal(batch.obs.reshape(-1), batch.index.float())  # obs t * 3 + env at row t * 3 + env
        seen += batch.index.tolist()
    assert sorted(seen) == list(range(12))
