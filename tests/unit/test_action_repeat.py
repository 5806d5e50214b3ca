"""env_config.action_repeat on envpool: each action held for k env steps, rewards summed, an env
that ends stops stepping (rlchain/envs/wrappers/action_repeat.py)."""

import numpy as np
import pytest

from rlchain.config.errors import ConfigError
from rlchain.envs.wrappers.action_repeat import repeat_step


class FakePool:
    """3 envs; env i's step reward is 10**i * (its action); env 1 terminates at its 2nd step, env 2
    is truncated at its 1st; obs = how many steps the env took; env 0 reports success at its 2nd step."""

    def __init__(self):
        self.steps = np.zeros(3, int)
        self.calls = []

    def step(self, actions, ids):
        self.calls.append(list(ids))
        self.steps[ids] += 1
        order = ids[::-1]  # envpool may answer in any order: rows are named by env_id
        act = dict(zip(ids.tolist(), actions.tolist()))
        reward = np.array([10.0 ** i * act[i] for i in order], np.float32)
        term = np.array([i == 1 and self.steps[i] == 2 for i in order])
        trunc = np.array([i == 2 and self.steps[i] == 1 for i in order])
        success = np.array([float(i == 0 and self.steps[i] == 2) for i in order])
        return self.steps[order].astype(np.float32), reward, term, trunc, {"env_id": order, "success": success,
                                                                           "elapsed_step": self.steps[order].copy()}


def test_repeat_sums_rewards_stops_ended_envs_and_keeps_any_success():
    pool, actions = FakePool(), np.array([1.0, 2.0, 3.0])
    ids = np.arange(3, dtype=np.int32)
    first = pool.step(actions, ids)
    first = tuple(x[::-1] for x in first[:4]) + ({k: v[::-1] for k, v in first[4].items()},)  # rows 0, 1, 2
    obs, reward, term, trunc, infos = repeat_step(pool.step, actions, first, repeat=3)
    # env 0: 3 steps of 1; env 1: 2 steps of 20 then its episode ended; env 2: truncated after 1 step of 300
    assert reward.tolist() == [3.0, 40.0, 300.0]
    assert obs.tolist() == [3.0, 2.0, 1.0] and pool.steps.tolist() == [3, 2, 1]
    assert term.tolist() == [False, True, False] and trunc.tolist() == [False, False, True]
    assert pool.calls[1:] == [[0, 1], [0]]  # env 2 never stepped again; env 1 not after it ended
    assert infos["success"].tolist() == [1.0, 0.0, 0.0]  # set at env 0's 2nd step, not its 3rd
    assert infos["elapsed_step"].tolist() == [3, 2, 1]  # other keys: the last step taken


def test_repeat_of_one_is_the_step_itself():
    pool, actions = FakePool(), np.array([1.0, 1.0, 1.0])
    first = pool.step(actions, np.arange(3, dtype=np.int32))
    out = repeat_step(pool.step, actions, first, repeat=1)
    assert len(pool.calls) == 1 and out[1].tolist() == first[1].tolist()


def test_envpool_action_repeat_matches_stepping_by_hand():
    """Pendulum (200-step time limit): one repeat-3 step = three plain steps with the same action,
    and the episode ends at decision 67 (66 * 3 = 198 steps, then 2)."""
    pytest.importorskip("envpool")
    from rlchain.envs.backends.envpool_env import EnvpoolVecEnv

    repeated = EnvpoolVecEnv("Pendulum-v1", 2, seed=3, action_repeat=3)
    plain = EnvpoolVecEnv("Pendulum-v1", 2, seed=3)
    try:
        assert np.allclose(repeated.reset(), plain.reset())
        rng = np.random.default_rng(0)
        for decision in range(1, 68):
            act = rng.uniform(-2, 2, (2, 1)).astype(np.float32)
            got = repeated.step(act)
            want_reward = np.zeros(2)
            for _ in range(3 if decision < 67 else 2):
                want = plain.step(act)
                want_reward += want.reward
            assert np.allclose(got.reward, want_reward, atol=1e-4)
            assert np.allclose(got.final_obs, want.final_obs, atol=1e-5)
            assert got.truncated.tolist() == [decision == 67] * 2
    finally:
        repeated.close()
        plain.close()


def test_envpool_action_repeat_with_env_groups_matches_one_pool():
    """env_groups > 1 (send/recv per group, as the pipelined rollout steps them): the same results."""
    pytest.importorskip("envpool")
    from rlchain.envs.backends.envpool_env import EnvpoolVecEnv

    grouped = EnvpoolVecEnv("Pendulum-v1", 4, seed=3, action_repeat=2, groups=2)
    single = EnvpoolVecEnv("Pendulum-v1", 4, seed=3, action_repeat=2)
    try:
        assert np.allclose(grouped.reset(), single.reset())
        act = np.linspace(-2, 2, 4, dtype=np.float32).reshape(4, 1)
        for _ in range(5):
            grouped.send(0, act[:2])
            grouped.send(1, act[2:])
            got = [grouped.recv(0), grouped.recv(1)]
            want = single.step(act)
            assert np.allclose(np.concatenate([r.reward for r in got]), want.reward, atol=1e-5)
            assert np.allclose(np.concatenate([r.obs for r in got]), want.obs, atol=1e-5)
    finally:
        grouped.close()
        single.close()


@pytest.mark.parametrize("bad", [0, -2, 2.5, "4", True])
def test_bad_action_repeat_is_a_one_line_config_error(bad):
    pytest.importorskip("envpool")
    from rlchain.envs.factory import make_vec_env

    with pytest.raises(ConfigError, match=r"params\.config\.env_config\.action_repeat: expected an integer >= 1"):
        make_vec_env("envpool", {"env_name": "Pendulum-v1", "action_repeat": bad}, 2, 0, None)
