"""Brax through the tensor-env contract (``env_name: brax``); skipped without the brax extra."""

import os
import pickle

import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt
from tests.conftest import CONFIGS, installed
from tests.jax_cache import jax_compile_cache  # noqa: F401 (module fixture: compile reset/step once)

pytestmark = [pytest.mark.smoke, installed("brax")]
CONFIG = os.path.join(CONFIGS, "ppo_brax_inverted_pendulum.yaml")


def test_contract_auto_reset_final_obs_and_time_limit():
    from rlchain.envs.backends.brax_env import BraxVecEnv
    env = BraxVecEnv("inverted_pendulum", 16, seed=3, episode_length=20, backend="spring")
    assert env.is_tensor_env and env.observation_space.shape == (4,) and env.action_space.shape == (1,)
    obs = env.reset(seed=3)
    assert obs.shape == (16, 4) and obs.dtype == torch.float32
    again = env.reset(seed=3)
    assert torch.equal(obs, again)  # seeded resets are reproducible
    terminated = truncated = 0
    steps = torch.zeros(16, dtype=torch.long)
    gen = torch.Generator().manual_seed(0)
    for _ in range(45):
        result = env.step(torch.rand(16, 1, generator=gen) * 2 - 1)
        for field in (result.obs, result.final_obs):
            assert field.shape == (16, 4) and field.dtype == torch.float32
        assert result.reward.shape == (16,) and result.terminated.dtype == torch.bool
        assert not bool((result.terminated & result.truncated).any())
        steps += 1
        done = result.terminated | result.truncated
        assert bool((result.truncated == (steps == 20) & ~result.terminated).all())  # time limit: 20 steps
        if bool(done.any()):  # ended rows start over: new obs differ from their final obs
            assert not torch.equal(result.obs[done], result.final_obs[done])
        steps[done] = 0
        terminated += int(result.terminated.sum())
        truncated += int(result.truncated.sum())
    assert terminated > 0 and truncated > 0
    # the step compiled once: the state the step hands back keeps the reset's types (no weak-typed float
    # leaves), so the jitted step's cache key is the same from the second step on (it compiled twice before)
    assert env._step_fn._cache_size() == 1 and env._reset_fn._cache_size() == 1


# the contract test's env shape (16 envs, 20 steps an episode): JAX compiles its reset and step once for the module
SHAPE = ["params.config.num_actors=16", "params.config.env_config.episode_length=20"]
PLAYER = ["params.config.player.use_vecenv=true", "params.config.player.num_actors=16"]


def test_shipped_config_train_play_resume(tmp_path):
    small = [f"params.config.train_dir={tmp_path}", "params.config.max_epochs=2", *SHAPE,
             "params.config.minibatch_size=256", "params.config.save_best_after=0", "params.config.print_stats=false"]
    result = Runner().load(CONFIG, small).train()
    assert result.epoch == 2 and result.frames == 2 * 16 * 64 and np.isfinite(result.mean_reward)
    last = os.path.join(result.run_dir, "nn", "last_brax_inverted_pendulum.pth")
    # the player's 16 envs (its default is 1): the module's one env shape, whose compiled reset and step are cached
    played = Runner().load(CONFIG, [*SHAPE, *PLAYER]).play(last, games=2, quiet=True)
    assert played.games == 2
    resumed = Runner().load(CONFIG, [*small, "params.config.max_epochs=3"]).train(checkpoint=last)
    assert resumed.epoch == 3 and ckpt.load(os.path.join(resumed.run_dir, "nn", os.path.basename(last)))["epoch"] == 3


@pytest.mark.parametrize("override,message", [
    ("params.config.env_config.env_name=antt", "params.config.env_config.env_name: brax has no env 'antt'"),
    ("params.config.env_config.episode_lenght=5", "params.config.env_config.episode_lenght: not a brax option"),
])
def test_bad_brax_config_is_one_line(tmp_path, override, message):
    with pytest.raises(ConfigError) as err:
        Runner().load(CONFIG, [override, f"params.config.train_dir={tmp_path}"]).train()
    text = str(err.value)
    assert message in text and "\n" not in text and "ppo_brax_inverted_pendulum.yaml" in text


def test_state_round_trip_continues_bit_identically():
    """Exact resume: get_state / set_state carry the JAX state pytree and key; after a set_state the env steps
    exactly as it did from that point (auto-resets and the time limit included); the whole run's resume is
    test_ppo_brax_resume_is_bit_identical below."""
    from rlchain.envs.backends.brax_env import BraxVecEnv
    env = BraxVecEnv("inverted_pendulum", 16, seed=3, episode_length=20, backend="spring")
    # built the same way as the contract test's env, it steps through that env's jitted reset and step (no new trace
    # or compile); another episode length is another function
    assert env._step_fn is BraxVecEnv("inverted_pendulum", 16, seed=9, episode_length=20, backend="spring")._step_fn
    assert env._step_fn is not BraxVecEnv("inverted_pendulum", 16, seed=3, episode_length=21, backend="spring")._step_fn
    env.reset(seed=3)
    gen = torch.Generator().manual_seed(0)
    actions = [torch.rand(16, 1, generator=gen) * 2 - 1 for _ in range(45)]
    for a in actions[:5]:
        env.step(a)
    saved = pickle.loads(pickle.dumps(env.get_state()))  # as a checkpoint stores it

    def run():
        out = []
        for a in actions[5:]:
            r = env.step(a)
            out.append(torch.cat([r.obs.flatten(), r.final_obs.flatten(), r.reward, r.terminated.float(),
                                  r.truncated.float()]))
        return torch.stack(out)

    first = run()
    env.set_state(saved)
    again = run()
    assert torch.equal(first, again)
    assert float(first[:, -16:].sum()) > 0  # the time limit (20 steps) was crossed after the snapshot
    assert env._step_fn._cache_size() == 1  # a restored (unpickled) state runs the compiled step


def test_ppo_brax_resume_is_bit_identical(tmp_path):
    """Exact resume end to end: PPO on Brax, 3 epochs + resume to 6 equals 6 straight (parameters, optimizer,
    episodes, every logged metric; torch.equal). The contract test's env shape (SHAPE), so the JAX compile cache
    of this module serves its reset and step."""
    from tests.smoke.test_exact_resume import check_split

    overrides = ["params.network.mlp.units=[16]", *SHAPE, "params.config.minibatch_size=256",
                 "params.config.mini_epochs=2", "params.config.save_best_after=0"]
    half = check_split(tmp_path, "ppo_brax_inverted_pendulum.yaml", overrides, 3)
    assert half["run_state"]["env"] is not None and half["episodes"]  # env state saved, episodes ended
