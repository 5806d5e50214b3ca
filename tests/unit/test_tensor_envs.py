"""Tensor envs: the VecEnv contract (auto-reset, final obs, time limit, seeding) and twin tests
against gymnasium's CartPole-v1 / Pendulum-v1 from identical states and actions."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.config.errors import ConfigError
from rlchain.envs.backends.tensor_env import TensorVecEnv
from rlchain.envs.backends.torch_envs import TorchCartPole, TorchPendulum, TorchReacher
from rlchain.envs.factory import make_vec_env
from rlchain.models.build import build_env
from rlchain.registry import ENVS

NAMES = ["TorchCartPole-v0", "TorchPendulum-v0", "TorchReacher8-v0"]
ATOL = RTOL = 1e-5  # float32 tensor envs against gymnasium's float64 state


def random_actions(env: TensorVecEnv, generator: torch.Generator) -> torch.Tensor:
    space = env.action_space
    if isinstance(space, gym.spaces.Discrete):
        return torch.randint(0, int(space.n), (env.num_envs,), generator=generator, device=env.device)
    low, high = torch.as_tensor(space.low, device=env.device), torch.as_tensor(space.high, device=env.device)
    return low + (high - low) * torch.rand((env.num_envs, *space.shape), generator=generator, device=env.device)


# ----- twin tests ------------------------------------------------------------------------------------

def _twin(gym_id: str, env: TensorVecEnv, gym_action, steps: int = 50, **gym_kwargs) -> dict:
    """Step ``env`` and one gymnasium env per row from the same states with the same actions;
    every transition (obs, reward, terminated, truncated) must agree. After a row's episode ends
    the gymnasium env is reset and set to the tensor env's new initial state."""
    n = env.num_envs
    env.reset(seed=3)
    twins = [gym.make(gym_id, **gym_kwargs) for _ in range(n)]

    def sync(i: int) -> None:
        twins[i].reset(seed=i)
        twins[i].unwrapped.state = env.state[i].double().numpy().copy()

    for i in range(n):
        sync(i)
    counts = {"terminated": 0, "truncated": 0, "compared": 0}
    rng = np.random.default_rng(0)
    for _ in range(steps):
        actions = gym_action(rng, n)
        res = env.step(torch.as_tensor(actions))
        for i, twin in enumerate(twins):
            g_obs, g_rew, g_term, g_trunc, _ = twin.step(actions[i])
            done = bool(res.terminated[i] or res.truncated[i])
            t_obs = res.final_obs[i] if done else res.obs[i]
            np.testing.assert_allclose(t_obs.numpy(), g_obs, rtol=RTOL, atol=ATOL)
            np.testing.assert_allclose(float(res.reward[i]), g_rew, rtol=RTOL, atol=ATOL)
            assert bool(res.terminated[i]) == g_term and bool(res.truncated[i]) == g_trunc
            counts["compared"] += 1
            counts["terminated"] += int(g_term)
            counts["truncated"] += int(g_trunc)
            if done:
                sync(i)
    for twin in twins:
        twin.close()
    return counts


def test_cartpole_twin_matches_gymnasium():
    env = TorchCartPole(16, seed=0)
    counts = _twin("CartPole-v1", env, lambda rng, n: rng.integers(0, 2, n))
    assert counts["terminated"] >= 16  # random pushes end episodes: resets are covered too


def test_cartpole_twin_from_spread_states():
    """Far from the initial distribution: large angles and speeds, all termination branches."""
    env = TorchCartPole(32, seed=0)
    env.reset(seed=0)
    gen = torch.Generator().manual_seed(1)
    scale = torch.tensor([2.0, 1.5, 0.18, 1.5])
    env.state = (torch.rand(32, 4, generator=gen) * 2 - 1) * scale

    twins = [gym.make("CartPole-v1") for _ in range(32)]
    for i, twin in enumerate(twins):
        twin.reset(seed=i)
        twin.unwrapped.state = env.state[i].double().numpy().copy()
    alive = np.ones(32, dtype=bool)
    rng = np.random.default_rng(1)
    for _ in range(30):
        actions = rng.integers(0, 2, 32)
        res = env.step(torch.as_tensor(actions))
        for i in np.flatnonzero(alive):
            g_obs, g_rew, g_term, _, _ = twins[i].step(actions[i])
            t_obs = res.final_obs[i] if res.terminated[i] else res.obs[i]
            np.testing.assert_allclose(t_obs.numpy(), g_obs, rtol=RTOL, atol=ATOL)
            assert float(res.reward[i]) == g_rew and bool(res.terminated[i]) == g_term
            alive[i] = not g_term
    assert alive.sum() < 32


def test_pendulum_twin_matches_gymnasium():
    env = TorchPendulum(16, seed=0)
    obs = env.reset(seed=5)
    ref = gym.make("Pendulum-v1")
    ref.reset(seed=0)
    ref.unwrapped.state = env.state[0].double().numpy()
    np.testing.assert_allclose(obs[0].numpy(), ref.unwrapped._get_obs(), rtol=RTOL, atol=ATOL)
    counts = _twin("Pendulum-v1", env,
                   lambda rng, n: rng.uniform(-2.5, 2.5, (n, 1)).astype(np.float32))  # beyond 2: clipped
    assert counts["compared"] == 16 * 50


def test_pendulum_twin_with_gravity_and_time_limit():
    env = TorchPendulum(4, seed=0, g=9.81, max_episode_steps=7)
    counts = _twin("Pendulum-v1", env, lambda rng, n: rng.uniform(-2, 2, (n, 1)).astype(np.float32),
                   steps=30, g=9.81, max_episode_steps=7)
    assert counts["truncated"] == 4 * 4  # steps 7, 14, 21, 28


def test_cartpole_twin_time_limit():
    """A balancing controller keeps the pole up; both envs truncate at the same step."""
    env = TorchCartPole(4, seed=0, max_episode_steps=40)

    def balance(rng, n):
        state = env.state.numpy()
        return (state[:, 2] + 0.5 * state[:, 3] > 0).astype(np.int64)

    counts = _twin("CartPole-v1", env, balance, steps=85, max_episode_steps=40)
    assert counts["truncated"] == 4 * 2 and counts["terminated"] == 0


# ----- the contract ----------------------------------------------------------------------------------

@pytest.mark.parametrize("name", NAMES)
def test_step_result_types(name):
    env = make_vec_env(name, {"device": "cpu"}, 6, 0, None)
    assert env.is_tensor_env and env.device == torch.device("cpu") and env.num_envs == 6
    obs = env.reset(seed=0)
    assert obs.shape == (6, *env.observation_space.shape) and obs.dtype == torch.float32
    gen = torch.Generator().manual_seed(0)
    for _ in range(3):
        res = env.step(random_actions(env, gen))
        assert res.obs.shape == res.final_obs.shape == (6, *env.observation_space.shape)
        assert res.obs.dtype == res.final_obs.dtype == res.reward.dtype == torch.float32
        assert res.reward.shape == res.terminated.shape == res.truncated.shape == (6,)
        assert res.terminated.dtype == res.truncated.dtype == torch.bool
        assert isinstance(res.infos, dict)
    assert env.observation_space.dtype == np.float32


def test_same_step_autoreset_and_final_obs():
    """Pushing right ends every cart-pole episode; done rows already hold a fresh first obs."""
    env = TorchCartPole(8, seed=0)
    obs = env.reset(seed=0)
    ends = 0
    for _ in range(40):
        prev_state = env.state.clone()
        res = env.step(torch.ones(8, dtype=torch.long))
        assert torch.all(res.reward == 1.0)
        done = res.terminated | res.truncated
        for i in done.nonzero().flatten().tolist():
            ends += 1
            assert abs(float(res.final_obs[i, 2])) > 0.2  # the pole fell: the true last obs
            assert torch.all(res.obs[i].abs() <= 0.05)  # the next episode's first obs
            assert torch.equal(res.obs[i], env.state[i])
            assert int(env.episode_steps[i]) == 0
            assert abs(float(res.final_obs[i, 0] - prev_state[i, 0])) < 0.1  # one step from the last state
        not_done = ~done
        assert torch.equal(res.obs[not_done], res.final_obs[not_done])
        obs = res.obs
    assert ends >= 8
    assert obs.shape == (8, 4)


def test_truncation_kept_apart_from_termination():
    env = TorchPendulum(3, seed=0)
    env.reset(seed=0)
    zero = torch.zeros(3, 1)
    for t in range(1, 201):
        res = env.step(zero)
        assert not res.terminated.any()
        assert bool(res.truncated.all()) == (t == 200)
    assert torch.equal(env.episode_steps, torch.zeros(3, dtype=torch.int32))
    # the truncated rows were reset: final_obs is the 200th obs, obs a fresh one
    assert not torch.equal(res.obs, res.final_obs)
    res = env.step(zero)
    assert not res.truncated.any()


def test_step_counter_is_per_env():
    env = TorchCartPole(2, seed=0, max_episode_steps=10)
    env.reset(seed=0)
    env.state[1, 2] = 0.2  # env 1 falls within a few steps, env 0 is balanced by the controller
    truncated_at, terminated_at = [], []
    for t in range(1, 16):
        actions = (env.state[:, 2] + 0.5 * env.state[:, 3] > 0).long()
        actions[1] = 0
        res = env.step(actions)
        if res.truncated[0]:
            truncated_at.append(t)
        if res.terminated[1]:
            terminated_at.append(t)
    assert truncated_at == [10] and terminated_at and terminated_at[0] < 10


def test_seeding_is_reproducible():
    def rollout(seed, reset_seed):
        env = TorchReacher(64, seed=seed)
        gen = torch.Generator().manual_seed(0)
        out = [env.reset(seed=reset_seed)]
        for _ in range(5):
            out.append(env.step(random_actions(env, gen)).obs)
        return torch.stack(out)

    assert torch.equal(rollout(1, 7), rollout(2, 7))  # reset(seed) decides
    assert torch.equal(rollout(1, None), rollout(1, None))  # else the constructor seed
    assert not torch.equal(rollout(1, 7), rollout(1, 8))
    env = TorchCartPole(4, seed=0)
    first = env.reset(seed=11)
    assert torch.equal(env.reset(seed=11), first)
    assert not torch.equal(env.reset(), first)  # no seed: the stream goes on


def test_resets_are_seeded_through_the_factory_seed():
    a = make_vec_env("TorchCartPole-v0", {}, 4, 5, None).reset()
    b = make_vec_env("TorchCartPole-v0", {}, 4, 5, None).reset()
    c = make_vec_env("TorchCartPole-v0", {}, 4, 6, None).reset()
    assert torch.equal(a, b) and not torch.equal(a, c)


def test_cartpole_initial_distribution():
    obs = TorchCartPole(200_000, seed=0).reset(seed=0)
    assert float(obs.min()) >= -0.05 and float(obs.max()) <= 0.05
    assert obs.mean(0).abs().max() < 1e-3
    torch.testing.assert_close(obs.std(0), torch.full((4,), 0.1 / math.sqrt(12)), atol=5e-4, rtol=0)


def test_pendulum_initial_distribution():
    env = TorchPendulum(200_000, seed=0)
    obs = env.reset(seed=0)
    th, thdot = torch.atan2(obs[:, 1], obs[:, 0]), obs[:, 2]
    torch.testing.assert_close(obs[:, :2].square().sum(1), torch.ones(200_000), atol=1e-5, rtol=0)
    assert float(thdot.min()) >= -1 and float(thdot.max()) <= 1 and abs(float(thdot.mean())) < 0.01
    assert float(th.min()) < -3.1 and float(th.max()) > 3.1 and abs(float(th.mean())) < 0.02
    torch.testing.assert_close(th.std(), torch.tensor(2 * math.pi / math.sqrt(12)), atol=0.01, rtol=0)


def test_reacher_kinematics_reward_and_targets():
    env = TorchReacher(512, seed=0)
    obs = env.reset(seed=0)
    n = env.num_links
    assert env.action_space.shape == (8,) and env.observation_space.shape == (3 * 8 + 4,)
    radius = env.target.norm(dim=1)
    assert float(radius.min()) >= 0.2 - 1e-6 and float(radius.max()) <= 0.9 + 1e-6
    gen = torch.Generator().manual_seed(0)
    actions = random_actions(env, gen) * 1.5  # beyond the box: clipped
    before_qd = env.qd.clone()
    res = env.step(actions)
    a = actions.clamp(-1, 1)
    qd = before_qd + env.dt * (env.gain * a - env.damping * before_qd)
    torch.testing.assert_close(env.qd, qd)
    for i in (0, 1, 511):  # forward kinematics, one link at a time
        angle, x, y = 0.0, 0.0, 0.0
        for j in range(n):
            angle += float(env.q[i, j])
            x += math.cos(angle) / n
            y += math.sin(angle) / n
        tip = torch.tensor([x, y])
        torch.testing.assert_close(res.obs[i, -2:], tip - env.target[i], atol=1e-5, rtol=0)
        expected = -float((tip - env.target[i]).norm()) - 0.01 * float(a[i].square().sum())
        assert abs(float(res.reward[i]) - expected) < 1e-5
    torch.testing.assert_close(res.obs[:, :n], torch.cos(env.q))
    torch.testing.assert_close(res.obs[:, 2 * n:3 * n], env.qd)
    assert obs.shape == (512, 28)


def test_reacher_greedy_controller_beats_random():
    """The reward is learnable: a Jacobian-transpose controller scores far above random actions."""
    def episode_return(policy):
        env = TorchReacher(256, seed=0)
        env.reset(seed=0)
        total = torch.zeros(256)
        gen = torch.Generator().manual_seed(0)
        for _ in range(200):
            total += env.step(policy(env, gen)).reward
        return float(total.mean())

    def jacobian_transpose(env, gen):
        angles = torch.cumsum(env.q, 1)
        err = env.target - env.fingertip(env.q)  # (N, 2)
        # d tip / d q_j = sum over links k >= j of (-sin, cos)(angle_k) / n
        dx = -torch.flip(torch.cumsum(torch.flip(torch.sin(angles), [1]), 1), [1]) / env.num_links
        dy = torch.flip(torch.cumsum(torch.flip(torch.cos(angles), [1]), 1), [1]) / env.num_links
        return (8 * (dx * err[:, :1] + dy * err[:, 1:]) - 0.5 * env.qd).clamp(-1, 1)

    rand = episode_return(random_actions)
    greedy = episode_return(jacobian_transpose)
    assert rand < -150 and greedy > -15, (rand, greedy)


def test_numpy_actions_and_shape_errors():
    env = TorchCartPole(3, seed=0)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(3, dtype=np.int64))
    env.reset()
    assert env.step(np.array([0, 1, 1])).obs.shape == (3, 4)
    assert env.step(torch.zeros(3, 1, dtype=torch.long)).obs.shape == (3, 4)  # (N, 1) columns
    with pytest.raises(ValueError, match="expected \\(3,\\)"):
        env.step(torch.zeros(4, dtype=torch.long))
    pend = TorchPendulum(3, seed=0)
    pend.reset()
    assert pend.step(np.zeros((3, 1), dtype=np.float64)).reward.dtype == torch.float32
    with pytest.raises(ValueError, match="expected \\(3, 1\\)"):
        pend.step(torch.zeros(3))


def test_registered_builders_and_config_errors(base_config):
    for name in NAMES:
        assert name in ENVS
    env = ENVS["TorchReacher8-v0"]["vecenv_creator"](5, 0, device="cpu", max_episode_steps=50)
    assert env.max_episode_steps == 50 and env.action_space.shape == (8,)
    with pytest.raises(ValueError, match="env_config.foo: not an option of TorchPendulum-v0"):
        make_vec_env("TorchPendulum-v0", {"foo": 1}, 2, 0, None)
    with pytest.raises(ValueError, match="does not render"):
        make_vec_env("TorchCartPole-v0", {}, 1, 0, None, render=True)
    with pytest.raises(ValueError, match="not a device"):
        make_vec_env("TorchCartPole-v0", {"device": "tpu"}, 1, 0, None)
    with pytest.raises(ValueError, match="max_episode_steps must be >= 1"):
        make_vec_env("TorchCartPole-v0", {"max_episode_steps": 0}, 1, 0, None)

    from rlchain.config.load import parse_params
    base_config["params"]["config"].update(env_name="TorchCartPole-v0", env_config={"devcie": "cpu"})
    params = parse_params(base_config, "cfg.yaml")
    with pytest.raises(ConfigError, match="cfg.yaml: params.config.env_config.devcie"):
        build_env(params, 4, 0)


def test_cuda_request_without_cuda_falls_back_to_cpu():
    if torch.cuda.is_available():
        pytest.skip("CUDA is available")
    with pytest.warns(UserWarning, match="CUDA is not available"):
        env = make_vec_env("TorchCartPole-v0", {"device": "cuda:0"}, 2, 0, None)
    assert env.device == torch.device("cpu")


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
@pytest.mark.parametrize("name", NAMES)
def test_cuda_step_stays_on_device(name):
    env = make_vec_env(name, {"device": "cuda"}, 4096, 0, None)
    obs = env.reset(seed=0)
    gen = torch.Generator(device=env.device).manual_seed(0)
    for _ in range(250):
        res = env.step(random_actions(env, gen))
    for value in (obs, res.obs, res.reward, res.terminated, res.truncated, res.final_obs):
        assert value.device.type == "cuda"


def test_push2d_pushes_the_cube_and_scores_embodichain_terms():
    from rlchain.envs.backends.torch_envs.push2d import WEIGHTS, TorchPush2D

    env = TorchPush2D(2, seed=0)
    env.reset(seed=0)
    env.state[:, 0:2] = torch.tensor([[0.0, -0.05], [0.3, 0.3]])  # env 0: just below its cube
    env.state[:, 2:4] = torch.tensor([[0.0, 0.0], [-0.3, -0.3]])
    env.state[:, 4:6] = torch.tensor([[0.0, 0.2], [0.2, 0.2]])
    result = env.step(torch.tensor([[0.0, 1.0], [0.0, 0.0]]))
    cube = env.state[:, 2:4]
    assert cube[0, 1].item() == pytest.approx(-0.05 + 0.03 + 0.045, abs=1e-5)
    assert cube[1].tolist() == pytest.approx([-0.3, -0.3])
    terms = env.last_terms
    expected = sum(WEIGHTS[k] * terms[k] for k in WEIGHTS)
    assert torch.allclose(result.reward, expected) and not result.infos["success"].any()


class TorchRooms(TensorVecEnv):
    """A tensor env with a Dict observation: a position (2,) and a Discrete room (start 1) as int64; 3-step
    episodes."""

    observation_space = gym.spaces.Dict({"pos": gym.spaces.Box(-1, 1, (2,), np.float32),
                                         "room": gym.spaces.Discrete(3, start=1)})
    action_space = gym.spaces.Discrete(2)

    def __init__(self, num_envs=4):
        super().__init__(num_envs, "cpu", 0, max_episode_steps=3)

    def _obs(self, k):
        from rlchain.envs.obs_dict import ObsDict

        room = torch.randint(1, 4, (k,), generator=self.generator)
        return ObsDict({"pos": torch.rand(k, 2, generator=self.generator), "room": room})

    def _reset_idx(self, env_ids):
        return self._obs(env_ids.numel())

    def _step_physics(self, actions):
        return self._obs(self.num_envs), actions.float(), torch.zeros(self.num_envs, dtype=torch.bool)


def test_a_tensor_env_s_dict_reaches_multi_input_per_key_with_its_discrete_key_an_integer():
    from rlchain import Runner
    from rlchain.envs.obs_dict import dict_zeros
    from rlchain.models.build import build_model
    from tests.conftest import CONFIGS

    params = Runner().load(f"{CONFIGS}/ppo_cartpole.yaml", ["params.network.name=multi_input",
                                                              "params.network.mlp.units=[8]"]).params
    env = TorchRooms()
    model = build_model(params, env, torch.device("cpu"))
    assert type(model.a2c_network.actor_cnn.encoders["room"]).__name__ == "EmbeddingEncoder"
    rollout = dict_zeros((4, 4), env.observation_space)  # the rollout storage's buffers
    obs = env.reset()
    for t in range(4):  # an episode ends at step 3: its rows reset inside the step, their room still an int64
        rollout[t] = obs
        obs = env.step(model.act(obs)["actions"]).obs
    assert rollout["room"].dtype == torch.int64 and bool(((rollout["room"] >= 1) & (rollout["room"] <= 3)).all())
