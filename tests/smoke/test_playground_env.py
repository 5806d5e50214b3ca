"""MuJoCo Playground through the tensor-env contract (``env_name: playground``); skipped without the extra."""

import os
import subprocess

import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt
from tests.conftest import CONFIGS, installed
from tests.jax_cache import jax_compile_cache  # noqa: F401 (module fixture: compile reset/step once)

pytestmark = [pytest.mark.smoke, installed("mujoco_playground")]
CONFIG = os.path.join(CONFIGS, "ppo_playground_cartpole.yaml")


def test_contract_auto_reset_final_obs_and_time_limit():
    from rlchain.envs.backends.playground_env import PlaygroundVecEnv
    env = PlaygroundVecEnv("CartpoleBalance", 8, seed=3, episode_length=20)
    assert env.is_tensor_env and env.observation_space.shape == (5,) and env.action_space.shape == (1,)
    obs = env.reset(seed=3)
    assert obs.shape == (8, 5) and obs.dtype == torch.float32
    assert torch.equal(obs, env.reset(seed=3))  # seeded resets are reproducible
    truncated = 0
    steps = torch.zeros(8, dtype=torch.long)
    gen = torch.Generator().manual_seed(0)
    for _ in range(45):
        result = env.step(torch.rand(8, 1, generator=gen) * 2 - 1)
        for field in (result.obs, result.final_obs):
            assert field.shape == (8, 5) and field.dtype == torch.float32
        assert result.reward.shape == (8,) and bool(((result.reward >= 0) & (result.reward <= 1)).all())
        assert not bool((result.terminated & result.truncated).any())
        steps += 1
        done = result.terminated | result.truncated
        assert bool((result.truncated == (steps == 20)).all())  # balance never terminates: time limit only
        if bool(done.any()):  # ended rows start over: new obs differ from their final obs
            assert not torch.equal(result.obs[done], result.final_obs[done])
        steps[done] = 0
        truncated += int(result.truncated.sum())
    assert truncated == 2 * 8
    assert env._step_fn._cache_size() == 1  # the step compiled once (a committed reset state)


def test_dict_observations_keep_the_state_entry():
    import jax.numpy as jnp

    from rlchain.envs.backends.playground_env import observation_picker
    size, pick = observation_picker({"state": (6,), "privileged_state": (9,)})
    obs = {"state": jnp.arange(12.0).reshape(2, 6), "privileged_state": jnp.zeros((2, 9))}
    assert size == 6 and np.array_equal(np.asarray(pick(obs)), np.arange(12.0).reshape(2, 6))
    assert observation_picker(5)[0] == 5
    with pytest.raises(ValueError, match="without a 'state' entry"):
        observation_picker({"pixels/view_0": (64, 64, 3)})


def test_shipped_config_train_play_resume(tmp_path):
    small = [f"params.config.train_dir={tmp_path}", "params.config.max_epochs=2", "params.config.num_actors=8",
             "params.config.horizon_length=16", "params.config.minibatch_size=64",
             "params.config.env_config.episode_length=20", "params.config.save_best_after=0",
             "params.config.print_stats=false"]
    result = Runner().load(CONFIG, small).train()
    assert result.epoch == 2 and result.frames == 2 * 8 * 16 and np.isfinite(result.mean_reward)
    assert 0 < result.mean_reward <= 20  # episodes of 20 steps, reward in [0, 1] per step
    last = os.path.join(result.run_dir, "nn", "last_playground_cartpole.pth")
    # the player's 8 envs (its default is 1): the contract test's env shape, whose compiled reset and step are cached
    player = ["params.config.player.use_vecenv=true", "params.config.player.num_actors=8"]
    played = Runner().load(CONFIG, ["params.config.env_config.episode_length=20", *player]).play(last, games=2,
                                                                                                quiet=True)
    assert played.games == 2
    resumed = Runner().load(CONFIG, [*small, "params.config.max_epochs=3"]).train(checkpoint=last)
    assert resumed.epoch == 3 and ckpt.load(os.path.join(resumed.run_dir, "nn", os.path.basename(last)))["epoch"] == 3


@pytest.mark.parametrize("override,message", [
    ("params.config.env_config.env_name=CartpoleBalanse",
     "params.config.env_config.env_name: MuJoCo Playground has no env 'CartpoleBalanse'; "
     "did you mean 'CartpoleBalance'"),
    ("params.config.env_config.episode_lenght=5",
     "params.config.env_config.episode_lenght: not a playground option"),
    ("params.config.env_config.config_overrides={ctrl_dtt: 0.02}",
     "params.config.env_config.config_overrides.ctrl_dtt: not a config key of Playground's CartpoleBalance"),
])
def test_bad_playground_config_is_one_line(tmp_path, override, message):
    with pytest.raises(ConfigError) as err:
        Runner().load(CONFIG, [override, f"params.config.train_dir={tmp_path}"]).train()
    text = str(err.value)
    assert message in text and "\n" not in text and "ppo_playground_cartpole.yaml" in text


def test_missing_menagerie_is_one_line(tmp_path, monkeypatch):
    """A Menagerie env without the assets: Playground's first-use git clone fails (offline) -> one line."""
    from mujoco_playground._src import mjx_env

    def offline_clone(*args, **kwargs):  # what git clone does without network access
        raise subprocess.CalledProcessError(128, ["git", "clone"])

    monkeypatch.setattr(mjx_env, "MENAGERIE_PATH", mjx_env.epath.Path(tmp_path / "mujoco_menagerie"))
    monkeypatch.setattr(mjx_env, "EXTERNAL_DEPS_PATH", mjx_env.epath.Path(tmp_path))
    monkeypatch.setattr(mjx_env, "_clone_with_progress", offline_clone)
    with pytest.raises(ConfigError) as err:
        Runner().load(CONFIG, ["params.config.env_config.env_name=PandaPickCube",
                               f"params.config.train_dir={tmp_path}"]).train()
    text = str(err.value)
    assert "\n" not in text and "ppo_playground_cartpole.yaml" in text and "PandaPickCube" in text
    assert "MuJoCo Menagerie" in text and "mujoco_menagerie.git" in text and "first use" in text
