"""VecEnv backends (gymnasium native/sync/async, envpool) and the env_name factory."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from rlchain import env_configurations
from rlchain.config.errors import ConfigError
from rlchain.envs.backends import envpool_env
from rlchain.envs.backends.envpool_env import EnvpoolVecEnv
from rlchain.envs.backends.gymnasium_env import GymnasiumVecEnv
from rlchain.envs.factory import make_vec_env
from rlchain.registry import ENVS, VECENVS

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

CARTPOLE_BACKENDS = ["native", "sync", "async", "envpool"]


def cartpole(vecenv_type: str, num_envs: int = 3, seed: int | None = 0, **env_config):
    """CartPole-v1 on one backend (skips envpool when it is not installed)."""
    if vecenv_type == "envpool":
        pytest.importorskip("envpool")
    return make_vec_env("CartPole-v1", env_config, num_envs, seed, vecenv_type)


@pytest.mark.parametrize("vecenv_type", CARTPOLE_BACKENDS)
def test_same_step_autoreset(vecenv_type):
    """Pushing right ends every episode; the done row's obs is already a fresh reset obs."""
    env = cartpole(vecenv_type)
    obs = env.reset(seed=0)
    seen_done = 0
    for _ in range(40):
        prev = obs
        res = env.step(np.ones(env.num_envs, dtype=np.int64))
        obs = res.obs
        # no deferred reset: a NEXT_STEP backend would give reward 0 on the step after done
        assert np.all(res.reward == 1.0)
        done = res.terminated | res.truncated
        assert not res.truncated.any()
        for i in np.flatnonzero(done):
            seen_done += 1
            assert np.abs(res.final_obs[i, 2]) > 0.2  # the pole fell: the true last obs
            assert np.all(np.abs(obs[i]) <= 0.05)  # reset state is uniform in [-0.05, 0.05]
            assert not np.allclose(res.final_obs[i], obs[i])
        for i in np.flatnonzero(~done):  # ordinary rows move a little from the previous obs
            assert np.abs(obs[i, 0] - prev[i, 0]) < 0.1
    assert seen_done >= env.num_envs
    env.close()


@pytest.mark.parametrize("vecenv_type", ["native", "sync", "envpool"])
def test_truncation_kept_apart_from_termination(vecenv_type):
    """A 5-step time limit truncates (not terminates) a balanced CartPole at step 5."""
    env = cartpole(vecenv_type, max_episode_steps=5)
    env.reset(seed=1)
    for t in range(1, 8):
        res = env.step(np.full(env.num_envs, t % 2))  # alternate pushes: the pole stays up
        assert not res.terminated.any() and np.all(res.reward == 1.0)
        assert res.truncated.all() == (t == 5) and res.truncated.any() == (t == 5)
        if t == 5:
            assert not np.allclose(res.final_obs, res.obs)
    env.close()


@pytest.mark.parametrize("vecenv_type", CARTPOLE_BACKENDS)
def test_seed_makes_runs_identical(vecenv_type):
    """Same seed and actions give the same trajectories, also when re-seeding a used env."""
    rng = np.random.default_rng(0)
    actions = rng.integers(0, 2, size=(30, 3))

    def run(env, seed):
        out = [env.reset(seed=seed)]
        for a in actions:
            res = env.step(a)
            out += [res.obs, res.final_obs, res.terminated]
        return out

    a, b = cartpole(vecenv_type), cartpole(vecenv_type)
    first = run(a, 7)
    for x, y, z in zip(first, run(b, 7), run(a, 7)):
        np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(x, z)
    assert not np.array_equal(run(b, 8)[0], first[0])
    a.close()
    b.close()


def test_sync_env_i_gets_seed_plus_i():
    """sync: env i seeded with seed + i, so env 1 of seed 0 equals env 0 of seed 1."""
    a, b = cartpole("sync", 2), cartpole("sync", 1)
    np.testing.assert_array_equal(a.reset(seed=0)[1], b.reset(seed=1)[0])


def test_constructor_seed_is_used_by_first_reset():
    a = make_vec_env("CartPole-v1", {}, 2, 3, "sync")
    b = make_vec_env("CartPole-v1", {}, 2, None, "sync")
    np.testing.assert_array_equal(a.reset(), b.reset(seed=3))


@pytest.mark.parametrize("vecenv_type", ["sync", "envpool"])
def test_pendulum_box_actions_and_dtypes(vecenv_type):
    """Box actions (float32 in, any shape (N, 1)); time limit from env_config truncates."""
    if vecenv_type == "envpool":
        pytest.importorskip("envpool")
    env = make_vec_env("Pendulum-v1", {"max_episode_steps": 3}, 4, 0, vecenv_type)
    obs = env.reset()
    assert obs.shape == (4, 3) and obs.dtype == np.float32
    assert env.action_space.shape == (1,) and env.action_space.dtype == np.float32
    for t in range(1, 4):
        res = env.step(np.full((4, 1), 0.5, dtype=np.float32))
        assert res.obs.shape == (4, 3) and res.obs.dtype == np.float32
        assert res.reward.shape == (4,) and res.reward.dtype == np.float32
        assert res.terminated.dtype == bool and res.truncated.dtype == bool
        assert res.truncated.all() == (t == 3) and not res.terminated.any()
    env.close()


@pytest.mark.parametrize("env_name,vecenv_type", [("HalfCheetah-v5", "sync"), ("HalfCheetah-v4", "envpool")])
def test_mujoco_obs_are_float32(env_name, vecenv_type):
    """MuJoCo obs are float64 in the env; the trainer gets float32 obs and spaces."""
    if vecenv_type == "envpool":
        pytest.importorskip("envpool")
    env = make_vec_env(env_name, {}, 2, 0, vecenv_type)
    assert env.observation_space.dtype == np.float32 and env.observation_space.shape == (17,)
    assert env.action_space.dtype == np.float32 and env.action_space.shape == (6,)
    obs = env.reset()
    res = env.step(np.zeros((2, 6), dtype=np.float32))
    assert obs.dtype == res.obs.dtype == res.final_obs.dtype == np.float32 and res.obs.shape == (2, 17)
    env.close()


def test_name_resolution():
    env = make_vec_env("CartPole-v1", {}, 2, 0, None)
    assert isinstance(env, GymnasiumVecEnv) and env.mode == "native"
    env = make_vec_env("openai_gym", {"name": "Pendulum-v1"}, 2, 0, "auto")
    assert isinstance(env, GymnasiumVecEnv) and env.mode == "sync" and env.action_space.shape == (1,)
    env = make_vec_env("CartPole-v1", {"max_episode_steps": 9}, 2, 0, "ASYNC")
    assert env.mode == "async"
    env.close()
    assert {"openai_gym", "envpool"} <= set(ENVS.names())
    assert {"gymnasium", "envpool"} <= set(VECENVS.names())


def test_envpool_name_resolution():
    pytest.importorskip("envpool")
    env = make_vec_env("envpool", {"env_name": "CartPole-v1", "seed": 5, "has_lives": False}, 2, 0, None)
    assert isinstance(env, EnvpoolVecEnv) and env.action_space.n == 2
    ref = make_vec_env("CartPole-v1", {}, 2, 5, "envpool")  # env_config.seed replaced seed 0
    assert isinstance(ref, EnvpoolVecEnv)
    np.testing.assert_array_equal(env.reset(), ref.reset())
    with pytest.raises(ConfigError, match=r"params\.config\.env_config\.episodic_lif\b.*not an envpool"):
        make_vec_env("envpool", {"env_name": "Pong-v5", "episodic_lif": True}, 2, 0, None)
    with pytest.raises(ConfigError, match=r"params\.config\.env_config\.env_name: .*'CartPole-v1'"):
        make_vec_env("envpool", {"env_name": "CartPol-v1"}, 2, 0, None)


def test_registered_env_builder(scoped_registries):
    """An entry's vecenv_creator is called as builder(num_envs, seed, **env_config)."""
    calls = []

    def builder(num_envs, seed, **env_config):
        calls.append((num_envs, seed, env_config))
        return "env"

    env_configurations.register("my_env", {"vecenv_creator": builder})
    assert make_vec_env("my_env", {"a": 1}, 4, 2, None) == "env"
    assert calls == [(4, 2, {"a": 1})]


@pytest.mark.parametrize("env_name,env_config,vecenv_type,pattern", [
    ("CartPol-v1", {}, None, r"^params\.config\.env_name: unknown environment 'CartPol-v1'; "
                             r"did you mean 'CartPole-v1'"),
    ("openai_gym", {"name": "Pendulm-v1"}, None, r"^params\.config\.env_config\.name: .*'Pendulum-v1'"),
    ("openai_gym", {}, None, r"^params\.config\.env_config\.name: is required"),
    ("CartPole-v1", {}, "subproc", r"^params\.config\.vecenv_type: unknown vecenv_type .subproc. "
                                         r"\(registered: async, auto, .*native, ray, sync"),
    ("Pendulum-v1", {}, "native", r"^params\.config\.vecenv_type: native is not available"),
    ("CartPole-v1", {"foo": 1}, "sync", r"^params\.config\.env_config\.foo: "),
    ("CartPole-v1", {"num_envs": 3}, None, r"^params\.config\.env_config\.num_envs: "),
])
def test_config_errors_are_one_line(env_name, env_config, vecenv_type, pattern):
    with pytest.raises(ValueError, match=pattern) as info:
        make_vec_env(env_name, env_config, 2, 0, vecenv_type)
    assert "\n" not in str(info.value)


def test_missing_envpool_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "envpool", None)
    envpool_env.envpool_tasks.cache_clear()
    with pytest.raises(ImportError, match=r"pip install rlchain\[envpool\]"):
        make_vec_env("envpool", {"env_name": "CartPole-v1"}, 2, 0, None)
    with pytest.raises(ImportError, match=r"pip install rlchain\[envpool\]"):
        make_vec_env("CartPole-v1", {}, 2, 0, "envpool")
    envpool_env.envpool_tasks.cache_clear()


def test_render_flag_uses_sync_with_human_mode():
    env = make_vec_env("CartPole-v1", {}, 1, 0, None, render=True)
    assert env.mode == "sync" and env.env.envs[0].render_mode == "human"
    env.close()


def test_env_configurations_register_creator():
    import gymnasium as gym

    from rlchain import env_configurations
    from rlchain.envs.factory import make_vec_env

    env_configurations.register("UserCartPole-test", {
        "env_creator": lambda **kw: gym.make("CartPole-v1", **kw), "max_episode_steps": 7})
    env = make_vec_env("UserCartPole-test", {}, 2, 0, None)
    env.reset()
    for _ in range(7):
        result = env.step(np.zeros(2, dtype=np.int64))
    assert result.truncated.all() or result.terminated.all()
    env.close()
    with pytest.raises(ValueError, match="already registered"):
        env_configurations.register("UserCartPole-test", {"env_creator": lambda **kw: None})


def test_envpool_groups_match_one_pool():
    """Two background-stepped pools give the rows of one pool, resets and final obs included."""
    pytest.importorskip("envpool")
    from rlchain.envs.backends.envpool_env import concat_results
    kwargs = {"max_episode_steps": 7}
    one = EnvpoolVecEnv("HalfCheetah-v4", 6, seed=3, env_kwargs=kwargs)
    two = EnvpoolVecEnv("HalfCheetah-v4", 6, seed=3, env_kwargs=kwargs, groups=2)
    assert two.env_groups == [slice(0, 3), slice(3, 6)]
    np.testing.assert_array_equal(one.reset(), two.reset())
    rng = np.random.default_rng(0)
    ended = 0
    for t in range(16):
        actions = rng.uniform(-1, 1, (6, 6)).astype(np.float32)
        a = one.step(actions)
        if t % 2:
            b = two.step(actions)
        else:  # send both groups, then collect them
            two.send(0, actions[:3])
            two.send(1, actions[3:])
            b = concat_results([two.recv(0), two.recv(1)])
        for field in ("obs", "reward", "terminated", "truncated", "final_obs"):
            np.testing.assert_allclose(getattr(a, field), getattr(b, field), atol=1e-6, err_msg=field)
        np.testing.assert_array_equal(b.infos["env_id"], np.arange(6))
        ended += int(b.truncated.sum())
    assert ended == 12  # every env ended twice (7-step episodes), reset in the same step
    one.close()
    two.close()


def test_envpool_groups_must_divide_envs():
    pytest.importorskip("envpool")
    with pytest.raises(ValueError, match="env_groups 4 must be >= 1 and divide the number of envs 6"):
        EnvpoolVecEnv("CartPole-v1", 6, seed=0, groups=4)
