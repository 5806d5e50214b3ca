"""The face's SAC, APPO and IMPALA, and PPO with RLlib's LSTM and convolutions, build and train a couple of
iterations on rlchain's algorithms in process, report RLlib's result keys and infer."""

import gymnasium as gym
import numpy as np
import pytest


def _train(config, iterations=2):
    """(algo, train() results, module outputs for one observation, a greedy and a sampled action)."""
    import torch

    algo = config.build_algo()
    try:
        results = [algo.train() for _ in range(iterations)]
        obs = algo.observation_space.sample()
        module = algo.get_module()
        outputs = module.forward_inference({"obs": torch.as_tensor(np.asarray(obs, np.float32)[None])})
        action = algo.compute_single_action(obs, explore=False)
        sampled = algo.compute_single_action(obs, explore=True)
        return algo, results, outputs, (action, sampled)
    finally:
        algo.stop()


def test_sac_trains_on_pendulum(tmp_path, monkeypatch):
    from rlchain.rllib.algorithms.sac import SACConfig

    monkeypatch.chdir(tmp_path)
    config = (SACConfig().environment("Pendulum-v1")
              .training(train_batch_size_per_learner=32, num_steps_sampled_before_learning_starts=50,
                        replay_buffer_config={"type": "PrioritizedEpisodeReplayBuffer", "capacity": 1000})
              .rl_module(model_config={"fcnet_hiddens": [16]})
              .reporting(min_sample_timesteps_per_iteration=60).debugging(seed=1))
    algo, results, outputs, actions = _train(config)
    assert algo.rlchain_config["params"]["algo"]["name"] == "sac"
    assert [r["num_env_steps_sampled_lifetime"] for r in results] == [60, 120]
    learner = results[-1]["learners"]["default_policy"]
    assert np.isfinite(learner["qf_loss"]) and np.isfinite(learner["alpha_value"])
    assert tuple(outputs["action_dist_inputs"].shape) == (1, 2)  # the pre-tanh mean, then the log-std
    for action in actions:
        assert np.asarray(action).shape == (1,) and -2.0 <= float(np.asarray(action)[0]) <= 2.0


@pytest.mark.parametrize("name", ["APPO", "IMPALA"])
def test_vtrace_algorithms_train_on_cartpole(name, tmp_path, monkeypatch):
    from rlchain.rllib.algorithms.appo import APPOConfig
    from rlchain.rllib.algorithms.impala import IMPALAConfig

    monkeypatch.chdir(tmp_path)
    config = ({"APPO": APPOConfig, "IMPALA": IMPALAConfig}[name]().environment("CartPole-v1")
              .env_runners(num_env_runners=2, rollout_fragment_length=16).training(train_batch_size=64)
              .rl_module(model_config={"fcnet_hiddens": [16]}).debugging(seed=1))
    algo, results, outputs, actions = _train(config)
    assert algo.rlchain_config["params"]["algo"]["name"] == name.lower()
    assert results[-1]["num_env_steps_sampled_lifetime"] >= 128
    assert np.isfinite(results[-1]["learners"]["default_policy"]["vf_loss"])
    assert tuple(outputs["action_dist_inputs"].shape) == (1, 2) and all(int(a) in (0, 1) for a in actions)


@pytest.mark.parametrize("name", ["APPO", "IMPALA"])
def test_vtrace_algorithms_train_an_lstm(name, tmp_path, monkeypatch):
    """use_lstm on APPO / IMPALA (APPO with its KL penalty too): the runners' LSTM, sequences that tile the
    fragment, RLlib's KL keys in the learner results."""
    from rlchain.rllib.algorithms.appo import APPOConfig
    from rlchain.rllib.algorithms.impala import IMPALAConfig

    monkeypatch.chdir(tmp_path)
    config = ({"APPO": APPOConfig, "IMPALA": IMPALAConfig}[name]().environment("CartPole-v1")
              .env_runners(num_env_runners=2, rollout_fragment_length=16).training(train_batch_size=64)
              .rl_module(model_config={"use_lstm": True, "lstm_cell_size": 8, "max_seq_len": 6,
                                       "fcnet_hiddens": [8]}).debugging(seed=1))
    if name == "APPO":
        config = config.training(use_kl_loss=True, kl_coeff=0.5, kl_target=0.01)
    algo, results, _, actions = _train(config)
    params = algo.rlchain_config["params"]
    assert params["network"]["rnn"]["units"] == 8 and params["config"]["seq_length"] == 4  # 16 = 4 x 4
    assert results[-1]["num_env_steps_sampled_lifetime"] >= 128 and all(int(a) in (0, 1) for a in actions)
    learner = results[-1]["learners"]["default_policy"]
    assert np.isfinite(learner["vf_loss"])
    if name == "APPO":
        assert np.isfinite(learner["mean_kl_loss"]) and learner["curr_kl_coeff"] > 0


def test_ppo_trains_an_lstm(tmp_path, monkeypatch):
    from rlchain.rllib.algorithms.ppo import PPOConfig

    monkeypatch.chdir(tmp_path)
    config = (PPOConfig().environment("CartPole-v1").env_runners(num_env_runners=1)
              .training(train_batch_size=64, minibatch_size=32, num_epochs=1)
              .rl_module(model_config={"use_lstm": True, "lstm_cell_size": 8, "max_seq_len": 8,
                                       "fcnet_hiddens": [8]}).debugging(seed=1))
    algo, results, _, _ = _train(config, 1)
    assert algo.rlchain_config["params"]["network"]["rnn"]["units"] == 8
    assert results[0]["num_env_steps_sampled_lifetime"] == 64
    assert algo.runner is not None


class TinyImages(gym.Env):
    """8x8 RGB frames; reward 1 when the action names the brighter half."""

    observation_space = gym.spaces.Box(0, 255, (8, 8, 3), np.uint8)
    action_space = gym.spaces.Discrete(2)

    def __init__(self, config=None):
        self.rng = np.random.default_rng(0)
        self.t = 0

    def _obs(self):
        self.side = int(self.rng.integers(2))
        frame = np.zeros((8, 8, 3), np.uint8)
        frame[:, self.side * 4:(self.side + 1) * 4] = 200
        return frame

    def reset(self, *, seed=None, options=None):
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.t = 0
        return self._obs(), {}

    def step(self, action):
        reward = float(int(action) == self.side)
        self.t += 1
        return self._obs(), reward, False, self.t >= 10, {}


def test_ppo_trains_convolutions_on_images(tmp_path, monkeypatch):
    from rlchain.rllib.algorithms.ppo import PPOConfig

    monkeypatch.chdir(tmp_path)
    config = (PPOConfig().environment(TinyImages).env_runners(num_env_runners=1)
              .training(train_batch_size=64, minibatch_size=32, num_epochs=1)
              .rl_module(model_config={"conv_filters": [[4, 3, 2], [8, 3, 2, "valid"]], "head_fcnet_hiddens": [8]})
              .debugging(seed=1))
    algo, results, outputs, _ = _train(config, 1)
    assert algo.rlchain_config["params"]["network"]["cnn"]["convs"][0]["filters"] == 4
    assert tuple(outputs["action_dist_inputs"].shape) == (1, 2)
    assert results[0]["num_env_steps_sampled_lifetime"] == 64


RAY_SCRIPT = """
import ray
ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
from rlchain.rllib.algorithms.appo import APPOConfig
from rlchain.rllib.algorithms.ppo import PPOConfig
algo = (PPOConfig().environment("CartPole-v1").env_runners(num_env_runners=2, num_envs_per_env_runner=2)
        .training(train_batch_size=256, minibatch_size=64, num_epochs=1).build_algo())
assert algo.rlchain_config["params"]["config"]["vecenv_type"] == "RAY"
assert type(algo._stepper.context.training_env).__name__ == "RayVecEnv", type(algo._stepper.context.training_env)
assert algo.train()["num_env_steps_sampled_lifetime"] == 256
algo.stop()
appo = (APPOConfig().environment("CartPole-v1").env_runners(num_env_runners=2, rollout_fragment_length=16)
        .training(train_batch_size=64).build_algo())
assert appo.rlchain_config["params"]["config"]["appo"]["runners"] == "ray"
assert appo.train()["num_env_steps_sampled_lifetime"] >= 64
appo.stop()
print("OK")
"""


@pytest.mark.slow
def test_env_runners_are_rays_after_ray_init(tmp_path):
    """After ray.init(), num_env_runners > 0 steps the envs on rlchain's Ray env runners (PPO) and Ray runner
    actors (APPO): a Ray start, tens of seconds."""
    import os
    import subprocess
    import sys

    pytest.importorskip("ray")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = {**os.environ, "PYTHONPATH": root, "OMP_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", RAY_SCRIPT], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0 and out.stdout.strip().endswith("OK"), out.stderr[-3000:]
