"""rlchain.sb3.callbacks and the SB3-shaped model with Stable-Baselines3's own objects: its vec envs as the env,
its callbacks run as written, get_env / set_env for evaluate_policy, reset_num_timesteps."""

import os

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from stable_baselines3.common.callbacks import (  # noqa: E402
    BaseCallback,
    CallbackList,
    CheckpointCallback,
    EvalCallback,
    StopTrainingOnRewardThreshold,
)
from stable_baselines3.common.env_util import make_vec_env  # noqa: E402
from stable_baselines3.common.evaluation import evaluate_policy  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv, VecNormalize  # noqa: E402

import rlchain  # noqa: E402
from rlchain.sb3.callbacks import SB3Logger  # noqa: E402

pytestmark = pytest.mark.smoke


def quiet(tmp_path):
    return {"verbose": 0, "tensorboard_log": str(tmp_path / "runs")}


class Recorder(BaseCallback):
    """Records SB3's events in order and stops after ``stop_after`` steps."""

    def __init__(self, stop_after: int = 10**9) -> None:
        super().__init__()
        self.events: list = []
        self.stop_after = stop_after

    def _on_training_start(self) -> None:
        self.events.append(("start", self.locals["total_timesteps"], self.training_env.num_envs))

    def _on_rollout_start(self) -> None:
        self.events.append("rollout_start")

    def _on_step(self) -> bool:
        loc = self.locals
        assert loc["new_obs"].shape == (2, 4) and loc["rewards"].shape == (2,) and loc["dones"].dtype == bool
        for done, info in zip(loc["dones"], loc["infos"]):
            if done:
                assert "terminal_observation" in info and "TimeLimit.truncated" in info and "episode" in info
        self.events.append(("step", self.num_timesteps, self.n_calls))
        self.logger.record("custom/calls", self.n_calls)
        return self.n_calls < self.stop_after

    def _on_rollout_end(self) -> None:
        self.events.append("rollout_end")

    def _on_training_end(self) -> None:
        self.events.append("end")


def test_base_callback_gets_sb3s_events_locals_and_counts(tmp_path):
    cb = Recorder()
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", n_envs=2, n_steps=8, batch_size=16, **quiet(tmp_path))
    model.learn(32, callback=cb)
    assert cb.events[0] == ("start", 32, 2) and cb.events[1] == "rollout_start"
    steps = [e for e in cb.events if isinstance(e, tuple) and e[0] == "step"]
    assert steps[0] == ("step", 2, 1) and steps[-1] == ("step", 32, 16)  # per vector step, n_envs frames each
    assert cb.events.count("rollout_start") == cb.events.count("rollout_end") == 2 and cb.events[-1] == "end"
    assert isinstance(model.logger, SB3Logger)


def test_on_step_false_stops_the_run(tmp_path):
    cb = Recorder(stop_after=3)
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", n_envs=2, n_steps=8, batch_size=16, **quiet(tmp_path))
    model.learn(10_000, callback=cb)
    assert model.num_timesteps < 100 and cb.events[-1] == "end"
    assert len([e for e in cb.events if isinstance(e, tuple) and e[0] == "step"]) == 3  # none after False


def test_logger_record_goes_to_the_run_writers(tmp_path):
    written = []

    class Writer:
        def add_scalar(self, tag, value, step):
            written.append((tag, value, step))

    logger = SB3Logger()
    logger.record("eval/mean_reward", 3.0)
    logger.record("time/total_timesteps", 8, exclude="tensorboard")
    logger.record("text", "not a number")
    logger.dump(8)  # outside a run: cleared, written nowhere
    assert not logger.name_to_value and not written
    logger.writer = Writer()
    logger.record_mean("a", 1.0)
    logger.record_mean("a", 3.0)
    logger.record("eval/mean_reward", 3.0)
    logger.record("time/total_timesteps", 8, exclude="tensorboard")
    logger.dump(16)
    assert sorted(written) == [("a", 2.0, 16), ("eval/mean_reward", 3.0, 16)]


def test_eval_checkpoint_and_stop_callbacks_write_sb3s_files(tmp_path):
    logs = str(tmp_path / "logs")
    stop = StopTrainingOnRewardThreshold(reward_threshold=-1e9)  # any evaluation is good enough: stops
    evaluation = EvalCallback(gym.make("CartPole-v1"), best_model_save_path=logs, log_path=logs, eval_freq=8,
                              n_eval_episodes=2, callback_on_new_best=stop)
    checkpoint = CheckpointCallback(save_freq=4, save_path=os.path.join(logs, "ck"))
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", n_envs=2, n_steps=8, batch_size=16, **quiet(tmp_path))
    model.learn(10_000, callback=CallbackList([checkpoint, evaluation]))
    assert model.num_timesteps < 100  # stopped by the threshold at the first evaluation
    results = np.load(os.path.join(logs, "evaluations.npz"))
    assert results["timesteps"].tolist() == [16] and results["results"].shape == (1, 2)
    assert any(name.startswith("best_model") for name in os.listdir(logs))
    assert os.listdir(os.path.join(logs, "ck"))


def test_sb3_vec_envs_train_and_get_env_returns_them(tmp_path):
    venv = VecNormalize(make_vec_env("Pendulum-v1", n_envs=2, seed=0))
    model = rlchain.PPO("MlpPolicy", venv, n_steps=16, batch_size=32, **quiet(tmp_path))
    checkpoint = CheckpointCallback(save_freq=32, save_path=str(tmp_path / "ck"), save_vecnormalize=True)
    model.learn(64, callback=checkpoint)
    assert model.get_env() is venv and model.get_vec_normalize_env() is venv
    assert "rl_model_vecnormalize_64_steps.pkl" in os.listdir(tmp_path / "ck")
    assert venv.obs_rms.count > 64  # SB3's statistics were updated by rlchain's steps
    venv.save(str(tmp_path / "vec_normalize.pkl"))  # and saved as SB3 saves them
    assert VecNormalize.load(str(tmp_path / "vec_normalize.pkl"), make_vec_env("Pendulum-v1")).obs_rms.count > 64
    dummy = DummyVecEnv([lambda: gym.make("CartPole-v1")] * 2)
    model = rlchain.DQN("MlpPolicy", dummy, learning_starts=16, batch_size=16, **quiet(tmp_path))
    assert model.n_envs == 2 and model.learn(64).num_timesteps >= 64


def test_get_env_is_a_vec_env_evaluate_policy_takes_and_set_env_checks_spaces(tmp_path):
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", n_envs=2, **quiet(tmp_path))
    env = model.get_env()
    assert isinstance(env, VecEnv) and env.num_envs == 2
    mean, std = evaluate_policy(model, env, n_eval_episodes=2)
    assert mean > 0
    model.set_env(make_vec_env("CartPole-v1", n_envs=3))
    assert model.n_envs == 3 and model.get_env().num_envs == 3
    with pytest.raises(ValueError, match="set_env: .*Pendulum-v1 has spaces"):
        model.set_env("Pendulum-v1")


def test_bad_total_timesteps_is_one_line(tmp_path):
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", **quiet(tmp_path))
    with pytest.raises(ValueError, match=r"^rlchain.PPO.learn: total_timesteps: expected a positive whole number"):
        model.learn("many")


def test_policy_save_is_sb3s_policy_file(tmp_path):
    from stable_baselines3.sac.policies import MlpPolicy

    model = rlchain.SAC("MlpPolicy", "Pendulum-v1", **quiet(tmp_path))
    path = str(tmp_path / "sac_policy")
    model.policy.save(path)
    saved = MlpPolicy.load(path)  # SB3's own class rebuilds it
    env = model.get_env()
    obs = env.reset()
    np.testing.assert_allclose(saved.predict(obs, deterministic=True)[0],
                               model.policy.predict(obs, deterministic=True)[0], atol=1e-6)
    mean, _ = evaluate_policy(model.policy, env, n_eval_episodes=1)
    assert mean < 0


def test_learning_rate_schedule_follows_progress(tmp_path):
    seen = []

    class Watch(rlchain.training.events.Callback):
        def on_epoch_end(self, ctx, stats, episodes):
            seen.append(ctx.get_params()["learning_rate"])

    model = rlchain.PPO("MlpPolicy", "CartPole-v1", n_steps=32, batch_size=32, learning_rate=lambda p: p * 1e-3,
                        **quiet(tmp_path))
    model.learn(128, callback=Watch())
    assert seen[0] == pytest.approx(1e-3) and seen[-1] < seen[1] < seen[0]


def test_checkpoint_callback_saves_the_live_replay_buffer(tmp_path):
    logs = str(tmp_path / "logs")
    checkpoint = CheckpointCallback(save_freq=100, save_path=logs, save_replay_buffer=True)
    model = rlchain.SAC("MlpPolicy", "Pendulum-v1", buffer_size=1000, learning_starts=50, batch_size=16,
                        **quiet(tmp_path))
    model.learn(200, callback=checkpoint)
    assert "rl_model_replay_buffer_100_steps.pkl" in os.listdir(logs)
    model.load_replay_buffer(os.path.join(logs, "rl_model_replay_buffer_100_steps.pkl"))
    assert model.replay_buffer.size() == 99  # as in SB3: on_step comes before the step is stored


def test_replay_buffer_save_and_load(tmp_path):
    model = rlchain.SAC("MlpPolicy", "Pendulum-v1", buffer_size=5000, learning_starts=50, batch_size=32,
                        **quiet(tmp_path))
    assert model.replay_buffer.size() == 0
    model.learn(200)
    assert model.replay_buffer.size() == 200 and model.replay_buffer.buffer_size == 5000
    model.save(str(tmp_path / "sac"))
    path = model.save_replay_buffer(str(tmp_path / "replay"))
    assert path.endswith("replay.pkl")
    loaded = rlchain.SAC.load(str(tmp_path / "sac"))
    assert loaded.replay_buffer.size() == 0
    loaded.load_replay_buffer(str(tmp_path / "replay"))
    assert loaded.replay_buffer.size() == 200
    again = rlchain.SAC.load(str(tmp_path / "sac"), env="Pendulum-v1")
    again.load_replay_buffer(path)
    again.learn(100)  # the run starts with the 200 saved transitions
    assert again.replay_buffer.size() == 300
