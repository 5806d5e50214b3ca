"""RLlib's episode callbacks on the face: ``on_episode_step`` runs after every env step of an episode (its last
too, before ``on_episode_end``) with the gymnasium vector env, the episode's last observation and its temporary
timestep data, as the callbacks page's Acrobot example uses them."""

import numpy as np
import pytest

from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.callbacks.callbacks import Episode, RLlibCallback, info_row


class Angles(RLlibCallback):
    steps = 0  # class-level: the config copies what it is given
    ended: list = []

    def on_episode_step(self, *, episode, env, **kwargs):
        Angles.steps += 1
        state = env.envs[kwargs["env_index"]].unwrapped.state
        if not episode.is_done:  # at the last step the row has already reset (same-step auto-reset)
            assert np.allclose(episode.get_observations(-1), state, atol=1e-6)
        episode.add_temporary_timestep_data("x", float(state[0]))

    def on_episode_end(self, *, episode, metrics_logger, **kwargs):
        xs = episode.get_temporary_timestep_data("x")
        Angles.ended.append((len(xs), episode.get_length(), sum(episode.get_rewards()), episode.get_return()))
        metrics_logger.log_value("x_mean", float(np.mean(xs)), window=50)


def test_on_episode_step_sees_every_step_with_the_env_and_its_last_observation(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    callback = Angles
    algo = (PPOConfig().environment("CartPole-v1").debugging(seed=0).callbacks(callbacks_class=Angles)
            .training(train_batch_size=256, minibatch_size=128, num_epochs=1).build_algo())
    try:
        result = algo.train()
    finally:
        algo.stop()
    assert callback.steps == 256 and algo.training_iteration == 1
    assert callback.ended and all(n == length and ret == r for n, length, r, ret in callback.ended)
    assert np.isfinite(result["env_runners"]["x_mean"])


def test_episode_step_functions_and_the_episodes_own_errors(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    lengths = []
    algo = (PPOConfig().environment("CartPole-v1").debugging(seed=0)
            .callbacks(on_episode_step=lambda episode, **kw: lengths.append(episode.get_length()))
            .training(train_batch_size=64, minibatch_size=64, num_epochs=1).build_algo())
    try:
        algo.train()
    finally:
        algo.stop()
    assert len(lengths) == 64 and min(lengths) == 1
    episode = Episode(0)
    with pytest.raises(KeyError, match="no temporary timestep data 'y'"):
        episode.get_temporary_timestep_data("y")
    with pytest.raises(IndexError, match="keeps its last observation only"):
        episode.get_observations(0)


def test_info_row_reads_gymnasiums_vector_info_masks():
    infos = {"a": np.array([1, 2]), "_a": np.array([True, False]), "b": np.array([3, 4])}
    assert info_row(infos, 0) == {"a": 1, "b": 3}
    assert info_row(infos, 1) == {"b": 4}
