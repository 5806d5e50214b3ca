"""Replay buffer against hand-computed values: terminal vs truncated, n-step returns, sum-tree sampling;
Dict observations stored per key in their own dtype."""

import os

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.algos.core.replay import ReplayBuffer, SumTree
from rlchain.config.errors import ConfigError
from rlchain.envs.obs_dict import ObsDict, obs_row_bytes
from tests.conftest import CONFIGS


def make(n_step=1, num_envs=1, gamma=0.5, capacity=16, **kw):
    return ReplayBuffer(capacity, (1,), (), "cpu", num_envs=num_envs, action_dtype=torch.long,
                        n_step=n_step, gamma=gamma, **kw)


def add(buf, obs, reward, next_obs, term=False, trunc=False, action=0):
    n = buf.num_envs
    buf.add(torch.full((n, 1), float(obs)), torch.full((n,), action), torch.full((n,), float(reward)),
            torch.full((n, 1), float(next_obs)), torch.full((n,), term), torch.full((n,), trunc))


def test_one_step_keeps_terminated_and_truncated_apart():
    buf = make()
    add(buf, 0, 1.0, 1)
    add(buf, 1, 2.0, 99, trunc=True)   # time-out: next_obs is the true final obs, still bootstrapped
    add(buf, 5, 3.0, 98, term=True)    # terminal
    assert len(buf) == 3
    assert buf.terminated[:3].tolist() == [False, False, True]
    assert buf.truncated[:3].tolist() == [False, True, False]
    assert buf.next_obs[:3, 0].tolist() == [1.0, 99.0, 98.0]
    assert buf.discounts[:3].tolist() == [0.5, 0.5, 0.5]


def test_n_step_return_hand_computed():
    # gamma 0.5, n 3: rewards 1, 2, 4, 8 -> first transition R = 1 + 0.5*2 + 0.25*4 = 3, discount 0.125
    buf = make(n_step=3)
    for t, r in enumerate([1.0, 2.0, 4.0, 8.0]):
        add(buf, t, r, t + 1)
    assert len(buf) == 2
    assert buf.rewards[:2].tolist() == [3.0, 2.0 + 0.5 * 4.0 + 0.25 * 8.0]
    assert buf.next_obs[:2, 0].tolist() == [3.0, 4.0]
    assert buf.discounts[:2].tolist() == [0.125, 0.125]
    assert not buf.terminated[:2].any()


def test_n_step_stops_at_episode_end():
    buf = make(n_step=3)
    add(buf, 0, 1.0, 1)
    add(buf, 1, 2.0, 50, term=True)   # episode ends here
    add(buf, 10, 4.0, 11)            # next episode: must not leak into the first transitions
    add(buf, 11, 8.0, 12, trunc=True)
    add(buf, 20, 16.0, 21)
    # t0: 1 + 0.5*2, terminal at obs 50, discount gamma^2 (unused since terminal)
    assert buf.rewards[0].item() == 2.0 and buf.terminated[0] and buf.next_obs[0, 0] == 50 and buf.discounts[0] == 0.25
    # t1: 2 only, terminal
    assert buf.rewards[1].item() == 2.0 and buf.terminated[1] and buf.discounts[1] == 0.5
    # t2: 4 + 0.5*8, truncated (not terminal) at obs 12, bootstrap with gamma^2
    assert buf.rewards[2].item() == 8.0 and not buf.terminated[2] and buf.truncated[2]
    assert buf.next_obs[2, 0] == 12 and buf.discounts[2] == 0.25


def test_n_step_per_env_independent():
    buf = make(n_step=2, num_envs=2)
    buf.add(torch.tensor([[0.0], [0.0]]), torch.zeros(2, dtype=torch.long), torch.tensor([1.0, 1.0]),
            torch.tensor([[1.0], [7.0]]), torch.tensor([False, True]), torch.tensor([False, False]))
    buf.add(torch.tensor([[1.0], [0.0]]), torch.zeros(2, dtype=torch.long), torch.tensor([2.0, 5.0]),
            torch.tensor([[2.0], [1.0]]), torch.tensor([False, False]), torch.tensor([False, False]))
    assert buf.rewards[:2].tolist() == [2.0, 1.0]
    assert buf.terminated[:2].tolist() == [False, True]
    assert buf.next_obs[:2, 0].tolist() == [2.0, 7.0]


def test_wraps_around_capacity():
    buf = make(capacity=4)
    for t in range(6):
        add(buf, t, float(t), t + 1)
    assert len(buf) == 4 and buf.pos == 2
    assert sorted(buf.obs[:, 0].tolist()) == [2.0, 3.0, 4.0, 5.0]


def test_uniform_sample_shapes():
    buf = make()
    for t in range(5):
        add(buf, t, 1.0, t + 1)
    batch = buf.sample(8, generator=torch.Generator().manual_seed(0))
    assert batch["obs"].shape == (8, 1) and batch["actions"].shape == (8,)
    assert torch.equal(batch["weights"], torch.ones(8))
    assert (batch["indices"] < 5).all()


def test_sum_tree_total_and_find():
    tree = SumTree(5)
    tree.update(np.arange(5), np.array([1.0, 2.0, 3.0, 4.0, 0.0]))
    assert tree.total == 10.0
    # prefix sums: [0,1) -> 0, [1,3) -> 1, [3,6) -> 2, [6,10) -> 3
    assert tree.find(np.array([0.0, 0.99, 1.0, 2.99, 3.0, 5.99, 6.0, 9.99])).tolist() == [0, 0, 1, 1, 2, 2, 3, 3]
    tree.update(np.array([3]), np.array([0.5]))
    assert tree.total == 6.5


def test_prioritized_sampling_proportions_and_weights():
    buf = make(capacity=4, prioritized=True, alpha=1.0, beta=1.0)
    for t in range(4):
        add(buf, t, 0.0, t + 1)
    buf.update_priorities(torch.arange(4), torch.tensor([1.0, 2.0, 3.0, 4.0]) - buf.eps)
    gen = torch.Generator().manual_seed(0)
    counts = np.zeros(4)
    for _ in range(200):
        batch = buf.sample(100, generator=gen)
        counts += np.bincount(batch["indices"].numpy(), minlength=4)
    freq = counts / counts.sum()
    np.testing.assert_allclose(freq, [0.1, 0.2, 0.3, 0.4], atol=0.01)
    # weights (N P_i)^-beta / max_j: with beta 1 they are P_min / P_i
    batch = buf.sample(100, generator=gen)
    expected = {0: 1.0, 1: 0.5, 2: 1 / 3, 3: 0.25}
    for i, w in zip(batch["indices"].tolist(), batch["weights"].tolist()):
        assert w == pytest.approx(expected[i], rel=1e-5)


def test_new_transitions_get_max_priority():
    buf = make(capacity=8, prioritized=True, alpha=1.0)
    add(buf, 0, 0.0, 1)
    buf.update_priorities(torch.tensor([0]), torch.tensor([5.0]))
    add(buf, 1, 0.0, 2)
    leaves = buf.tree.leaves(2)
    assert leaves[1] == pytest.approx(leaves[0])


def test_state_dict_round_trip():
    buf = make(n_step=2, capacity=8, prioritized=True)
    for t in range(5):
        add(buf, t, float(t), t + 1)
    other = make(n_step=2, capacity=8, prioritized=True)
    other.load_state_dict(buf.state_dict())
    assert len(other) == len(buf) and other.pos == buf.pos
    assert torch.equal(other.rewards, buf.rewards) and torch.equal(other.obs, buf.obs)
    np.testing.assert_allclose(other.tree.leaves(), buf.tree.leaves())
    add(buf, 5, 5.0, 6)
    add(other, 5, 5.0, 6)   # the pending n-step window came along too
    assert torch.equal(other.rewards, buf.rewards)


DICT_SPACE = gym.spaces.Dict({"image": gym.spaces.Box(0, 255, (1, 4, 4), np.uint8),
                              "vec": gym.spaces.Box(-1, 1, (2,), np.float32)})


def dict_obs(value, n=2):
    return ObsDict({"image": torch.full((n, 1, 4, 4), value, dtype=torch.uint8),
                    "vec": torch.full((n, 2), value / 10.0)})


def add_dict(buf, value, next_value, term=False, n=2):
    buf.add(dict_obs(value, n), torch.zeros(n, dtype=torch.long), torch.full((n,), float(value)),
            dict_obs(next_value, n), torch.full((n,), term), torch.zeros(n, dtype=torch.bool))


def test_dict_observations_stored_per_key_in_their_dtype_and_sampled_back():
    buf = ReplayBuffer(8, DICT_SPACE, (), "cpu", num_envs=2, action_dtype=torch.long)
    assert buf.obs["image"].dtype == torch.uint8 and buf.next_obs["image"].dtype == torch.uint8
    assert buf.obs["vec"].dtype == torch.float32 and buf.obs["image"].shape == (8, 1, 4, 4)
    for value in (200, 201, 202):
        add_dict(buf, value, value + 50)
    batch = buf.sample(16, generator=torch.Generator().manual_seed(0))
    obs, nxt = batch["obs"], batch["next_obs"]
    assert isinstance(obs, ObsDict) and obs.shape == (16,) and obs["image"].dtype == torch.uint8
    # every sampled row is the transition stored at its index: image value v, vec v / 10, next image v + 50
    value = batch["rewards"].long()
    assert torch.equal(obs["image"].flatten(1), value[:, None].expand(16, 16).to(torch.uint8))
    assert torch.equal(nxt["image"][:, 0, 0, 0], (value + 50).to(torch.uint8))
    assert torch.allclose(obs["vec"], (value.float() / 10.0)[:, None].expand(16, 2))


def test_dict_n_step_and_state_dict_round_trip():
    buf = ReplayBuffer(8, DICT_SPACE, (), "cpu", num_envs=2, action_dtype=torch.long, n_step=2, gamma=0.5)
    add_dict(buf, 1, 2)
    add_dict(buf, 2, 3, term=True)   # the first transition's n-step next_obs is this step's, then it stops
    add_dict(buf, 4, 5)
    assert len(buf) == 4 and buf.next_obs["image"][:2, 0, 0, 0].tolist() == [3, 3]
    assert buf.rewards[:2].tolist() == [1.0 + 0.5 * 2.0] * 2
    state = buf.state_dict()
    assert type(state["obs"]) is dict and type(state["pending"][0]["obs"]) is dict  # plain: weights_only loads it
    other = ReplayBuffer(8, DICT_SPACE, (), "cpu", num_envs=2, action_dtype=torch.long, n_step=2, gamma=0.5)
    other.load_state_dict(state)
    for key in ("image", "vec"):
        assert torch.equal(other.obs[key], buf.obs[key]) and torch.equal(other.next_obs[key], buf.next_obs[key])
    add_dict(buf, 6, 7)
    add_dict(other, 6, 7)  # the pending window (an ObsDict again) came along
    assert torch.equal(other.next_obs["image"], buf.next_obs["image"])


def test_obs_row_bytes_per_key_and_flat():
    assert obs_row_bytes(DICT_SPACE) == 16 + 8
    assert obs_row_bytes(gym.spaces.Dict({**DICT_SPACE.spaces, "room": gym.spaces.Discrete(4)})) == 16 + 8 + 8
    assert obs_row_bytes(gym.spaces.Box(0, 255, (1, 4, 4), np.uint8)) == 16
    assert obs_row_bytes(gym.spaces.Box(-1, 1, (3,), np.float32)) == 12


def test_n_step_range_draws_each_transitions_n_and_sums_that_many_rewards():
    # RLlib's n_step=(2, 5): n in 2..4; gamma 0.5, rewards 1, 2, 4, 8, ...: a row that used n steps has
    # discount 0.5^n and return sum_{k<n} 0.5^k * 2^(t+k) = n * 2^t
    torch.manual_seed(0)
    buf = make(n_step=2, n_step_max=4, capacity=64)
    for t in range(40):
        add(buf, t, float(2 ** t), t + 1)
    assert len(buf) == 40 - 3  # the window holds n_step_max steps before the first write
    used = np.rint(np.log(buf.discounts[:len(buf)].numpy()) / np.log(0.5)).astype(int)
    assert set(used.tolist()) == {2, 3, 4}
    for t in range(len(buf)):
        assert buf.rewards[t].item() == used[t] * 2.0 ** t
        assert buf.next_obs[t, 0].item() == t + used[t]


def test_n_step_range_still_stops_at_episode_end():
    torch.manual_seed(1)
    buf = make(n_step=2, n_step_max=3)
    add(buf, 0, 1.0, 1)
    add(buf, 1, 2.0, 50, term=True)
    add(buf, 10, 4.0, 11)
    add(buf, 11, 8.0, 12)
    assert buf.rewards[0].item() == 2.0 and buf.terminated[0] and buf.discounts[0] == 0.25  # 2 steps to the end
    assert buf.rewards[1].item() == 2.0 and buf.terminated[1] and buf.discounts[1] == 0.5


def test_n_step_max_at_n_step_is_the_fixed_n():
    assert make(n_step=3, n_step_max=3).n_step_max is None and make(n_step=3, n_step_max=3).window == 3


@pytest.mark.parametrize("overrides, key, says", [
    (["params.config.n_step=3", "params.config.n_step_max=2"], "n_step_max", "n_step_max 2 is below n_step 3"),
    (["params.config.n_step_max=four"], "n_step_max", "expected"),
])
def test_a_bad_n_step_max_is_a_one_line_error_naming_the_file_and_key(overrides, key, says):
    with pytest.raises(ConfigError, match=rf"dqn_cartpole.yaml: params.config.{key}: .*{says}") as err:
        Runner().load(os.path.join(CONFIGS, "dqn_cartpole.yaml"), overrides)
    assert "\n" not in str(err.value)
