"""The face's SAC, APPO and IMPALA configs, RLlib's model settings (LSTM, convolutions, head layers) and its env
runners, translated onto rlchain's keys (rlchain.rllib.algorithms.*.translate, networks, env_runners)."""

import gymnasium as gym
import numpy as np
import pytest

from rlchain.config.errors import ConfigError
from rlchain.config.load import parse_params
from rlchain.rllib import env_runners, networks, translate
from rlchain.rllib.algorithms.appo import APPOConfig
from rlchain.rllib.algorithms.dqn import DQNConfig
from rlchain.rllib.algorithms.impala import IMPALAConfig
from rlchain.rllib.algorithms.impala.translate import vtrace_config
from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.algorithms.sac import SACConfig
from rlchain.rllib.algorithms.sac.translate import sac_config

FLAT = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)
IMAGE = gym.spaces.Box(0, 255, (42, 42, 3), np.uint8)


def test_sac_defaults_are_rllibs_and_map_onto_rlchains_sac():
    c = SACConfig()
    assert (c.actor_lr, c.critic_lr, c.alpha_lr, c.tau, c.initial_alpha, c.target_entropy) == \
        (3e-5, 3e-4, 3e-4, 5e-3, 1.0, "auto")
    assert (c.train_batch_size, c.num_steps_sampled_before_learning_starts, c.twin_q, c.n_step) == (256, 1500, True, 1)
    params = sac_config(c, "Pendulum-v1", {})["params"]
    cfg = params["config"]
    assert params["algo"]["name"] == "sac" and params["model"]["name"] == "soft_actor_critic"
    assert (cfg["actor_lr"], cfg["critic_lr"], cfg["alpha_lr"], cfg["init_alpha"], cfg["critic_tau"]) == \
        (3e-5, 3e-4, 3e-4, 1.0, 5e-3)
    assert cfg["target_entropy"] is None  # rlchain's default is RLlib's "auto": -action dims
    assert (cfg["batch_size"], cfg["replay_buffer_size"], cfg["prioritized_replay"]) == (256, 1_000_000, True)
    assert (cfg["num_warmup_frames"], cfg["num_steps_per_episode"], cfg["num_updates_per_step"]) == (1500, 100, 1)
    assert cfg["num_actors"] == 1 and cfg["clip_actions"] and cfg["log_std_bounds"] == [-20.0, 20.0]
    assert cfg["loss"] == "huber"  # RLlib's critic loss
    assert not cfg["save_replay_buffer"]
    assert sac_config(SACConfig().training(store_buffer_in_checkpoints=True), "Pendulum-v1", {})["params"][
        "config"]["save_replay_buffer"]
    # RLlib's DefaultModelConfig: an MLP of 256, 256 with tanh for the actor and both critics
    assert params["network"]["mlp"]["units"] == [256, 256] and params["network"]["mlp"]["activation"] == "tanh"


def test_sac_settings_and_what_it_refuses():
    c = SACConfig().training(actor_lr=1e-3, target_entropy=-2.0, tau=0.01, n_step=3, train_batch_size_per_learner=128,
                             replay_buffer_config={"type": "EpisodeReplayBuffer", "capacity": 5000},
                             training_intensity=512).rl_module(
        model_config={"fcnet_hiddens": [64], "fcnet_activation": "relu", "head_fcnet_hiddens": [32],
                      "head_fcnet_activation": "relu"})
    params = sac_config(c, "Pendulum-v1", {})["params"]
    cfg = params["config"]
    assert (cfg["actor_lr"], cfg["target_entropy"], cfg["critic_tau"], cfg["n_step"]) == (1e-3, -2.0, 0.01, 3)
    assert (cfg["batch_size"], cfg["replay_buffer_size"], cfg["prioritized_replay"]) == (128, 5000, False)
    # native ratio 128 / (3 x 1 x 1) = 42.7; 512 / 42.7 = 12 updates after each round of 3 steps
    assert (cfg["num_updates_per_step"], cfg["update_every"]) == (12, 3)
    assert params["network"]["mlp"]["units"] == [64, 32]
    # RLlib 2.60's SACConfig sets train_batch_size_per_learner (256): train_batch_size alone changes nothing
    assert sac_config(SACConfig().training(train_batch_size=16), "Pendulum-v1", {})["params"]["config"][
        "batch_size"] == 256
    for build, key in ((lambda c: c.training(twin_q=False), "twin_q"),
                       (lambda c: c.training(target_network_update_freq=10), "target_network_update_freq"),
                       (lambda c: c.training(n_step=(3, 3)), "n_step"),
                       (lambda c: c.training(n_step=(2, 5), target_network_update_freq=1, training_intensity=2048),
                        "target_network_update_freq"),  # freq 1 with several updates after each round
                       (lambda c: c.rl_module(model_config={"use_lstm": True}), "use_lstm"),
                       (lambda c: c.rl_module(model_config={"conv_filters": [[8, 3, 1]]}), "conv_filters")):
        with pytest.raises(ConfigError, match=key) as info:
            sac_config(build(SACConfig()), "Pendulum-v1", {})
        assert "\n" not in str(info.value)


def test_sac_as_rllibs_tuned_pendulum_sets_it_n_step_range_and_target_updates():
    # pendulum_sac.py: n_step=(2, 5), target_network_update_freq=1: RLlib draws n from 2..4 (numpy's integers) and
    # its learner moves the targets after every update (each follows >= 1 new env step), as rlchain's SAC does
    c = SACConfig().training(n_step=(2, 5), target_network_update_freq=1)
    cfg = sac_config(c, "Pendulum-v1", {})["params"]["config"]
    assert (cfg["n_step"], cfg["n_step_max"], cfg["update_every"], cfg["num_updates_per_step"]) == (2, 4, 5, 1)
    assert sac_config(SACConfig().training(n_step=(2, 3)), "Pendulum-v1", {})["params"]["config"]["n_step_max"] \
        is None  # integers(2, 3) is always 2
    dqn = translate.dqn_config(DQNConfig().environment("CartPole-v1").training(n_step=(2, 5)), "CartPole-v1",
                               {})["params"]["config"]
    assert (dqn["n_step"], dqn["n_step_max"], dqn["update_every"]) == (2, 4, 5)


def test_impala_defaults_map_onto_rlchains_impala():
    c = IMPALAConfig()
    assert (c.lr, c.vf_loss_coeff, c.entropy_coeff, c.grad_clip, c.rollout_fragment_length, c.train_batch_size) == \
        (5e-4, 0.5, 0.01, 40.0, 50, 500)
    params = vtrace_config(c, "CartPole-v1", FLAT, False, {})["params"]
    cfg = params["config"]
    assert params["algo"]["name"] == "impala" and params["network"]["separate"] is False  # shared value layers
    # RLlib's learner batch of 500 from 2 runners' fragments of 50: rlchain's batch is one fragment of every env,
    # so each of the 2 runners holds 5 envs
    assert (cfg["num_actors"], cfg["horizon_length"], cfg["minibatch_size"]) == (10, 50, 500)
    assert cfg["env_runners"] == {"num_workers": 2, "envs_per_worker": 5, "max_restarts": 1000}
    assert (cfg["learning_rate"], cfg["critic_coef"], cfg["entropy_coef"], cfg["grad_norm"]) == (5e-4, 0.5, 0.01, 40.0)
    assert cfg["truncate_grads"] and not cfg["normalize_advantage"] and "mini_epochs" not in cfg
    assert cfg["appo"]["vtrace_clip_rho"] == 1.0 and cfg["appo"]["vtrace_clip_c"] == 1.0
    assert cfg["appo"]["runners"] == "local"
    with pytest.raises(ConfigError, match="num_epochs.*one pass"):
        vtrace_config(IMPALAConfig().training(num_epochs=2), "CartPole-v1", FLAT, False, {})


def test_appo_maps_its_surrogate_and_circular_buffer():
    c = APPOConfig().training(clip_param=0.2, train_batch_size=1000, minibatch_size=250).env_runners(
        num_env_runners=4, rollout_fragment_length=25)
    params = vtrace_config(c, "CartPole-v1", FLAT, False, {})["params"]
    cfg = params["config"]
    assert params["algo"]["name"] == "appo" and params["network"]["separate"]  # APPO: no shared value layers
    assert (cfg["e_clip"], cfg["mini_epochs"], cfg["clip_value"]) == (0.2, 2, False)
    assert (cfg["num_actors"], cfg["horizon_length"], cfg["minibatch_size"]) == (40, 25, 250)
    assert "kl_loss_coef" not in cfg and "seq_length" not in cfg and "rnn" not in params["network"]
    for build, key in ((lambda c: c.training(use_kl_loss=True, tau=0.5), "tau"),
                       (lambda c: c.training(vtrace=False), "vtrace"),
                       (lambda c: c.training(vtrace_clip_pg_rho_threshold=2.0), "vtrace_clip_pg_rho_threshold")):
        with pytest.raises(ConfigError, match=key) as info:
            vtrace_config(build(APPOConfig()), "CartPole-v1", FLAT, False, {})
        assert "\n" not in str(info.value)


def test_appo_kl_penalty_maps_onto_the_target_policy_penalty():
    # pendulum_appo.py's: the target network refreshes every 2 x 16 x 10 x 500 env steps trained; rlchain's update
    # trains 10 passes over 20 envs x 50 steps: every 16 updates
    c = APPOConfig().training(use_kl_loss=True, kl_coeff=1.0, kl_target=0.04, target_network_update_freq=2,
                              circular_buffer_num_batches=16, circular_buffer_iterations_per_batch=10,
                              train_batch_size_per_learner=500).env_runners(num_env_runners=1,
                                                                            num_envs_per_env_runner=20)
    params = vtrace_config(c, "Pendulum-v1", gym.spaces.Box(-1, 1, (3,)), True, {})
    cfg = params["params"]["config"]
    assert (cfg["kl_loss_coef"], cfg["kl_loss_target"], cfg["mini_epochs"]) == (1.0, 0.04, 10)
    assert (cfg["num_actors"], cfg["horizon_length"], cfg["target_update_interval"]) == (20, 50, 16)
    assert parse_params(params, "face").config.kl_loss_coef == 1.0
    off = vtrace_config(c.copy().training(kl_coeff=0.0), "Pendulum-v1", gym.spaces.Box(-1, 1, (3,)), True, {})
    assert "kl_loss_coef" not in off["params"]["config"]


@pytest.mark.parametrize("config_class", [APPOConfig, IMPALAConfig])
def test_vtrace_lstm_maps_onto_rnn_sequences_that_tile_the_fragment(config_class):
    c = config_class().rl_module(model_config={"use_lstm": True, "lstm_cell_size": 32, "max_seq_len": 20,
                                               "vf_share_layers": True}).training(minibatch_size=170)
    out = vtrace_config(c, "CartPole-v1", FLAT, False, {})
    params = out["params"]
    cfg = params["config"]
    assert params["network"]["rnn"] == {"name": "lstm", "units": 32, "layers": 1, "before_mlp": False}
    # fragments of 50: sequences of 10 (the longest <= 20 that tiles 50); 500 frames: minibatches of 100 (170 is
    # not whole sequences dividing the batch: the nearest smaller that is)
    assert (cfg["horizon_length"], cfg["seq_length"], cfg["minibatch_size"]) == (50, 10, 100)
    assert parse_params(out, "face").config.seq_length == 10


def test_lstm_maps_onto_rlchains_rnn_with_whole_sequences():
    for c in (PPOConfig().rl_module(model_config={"use_lstm": True, "lstm_cell_size": 64, "max_seq_len": 20,
                                                  "fcnet_hiddens": [32]}),
              PPOConfig().training(model={"use_lstm": True, "lstm_cell_size": 64, "max_seq_len": 20,
                                          "fcnet_hiddens": [32]})):
        params = translate.ppo_config(c, "CartPole-v1", False, {}, FLAT)["params"]
        cfg = params["config"]
        assert params["network"]["rnn"] == {"name": "lstm", "units": 64, "layers": 1, "before_mlp": False}
        assert params["network"]["mlp"]["units"] == [32] and cfg["seq_length"] == 20
        # 4000 over 2 envs in sequences of 20: 2000 steps each; 200 sequences in minibatches of 5 (100 steps), the
        # whole number of sequences dividing the batch nearest RLlib's 128
        assert (cfg["horizon_length"], cfg["minibatch_size"]) == (2000, 100)


@pytest.mark.parametrize("batch, envs, minibatch, seq, shape", [(4000, 2, 128, 20, (2000, 100)),
                                                                (4000, 2, 128, 16, (2000, 160)),
                                                                (1000, 3, 100, 8, (336, 112))])
def test_sequence_batch_shape(batch, envs, minibatch, seq, shape):
    steps, size = translate.sequence_batch_shape(batch, envs, minibatch, seq)
    assert (steps, size) == shape
    assert steps % seq == 0 and size % seq == 0 and (envs * steps) % size == 0 and envs * steps >= batch


def test_conv_filters_map_onto_rlchains_cnn():
    c = PPOConfig().rl_module(model_config={"conv_filters": [[16, [4, 4], 2], [32, 3, 2, "valid"]],
                                            "head_fcnet_hiddens": [64], "conv_activation": "elu"})
    params = translate.ppo_config(c, "env", False, {}, IMAGE)["params"]
    network = params["network"]
    assert network["cnn"]["convs"] == [{"filters": 16, "kernel_size": 4, "strides": 2, "padding": 1},
                                       {"filters": 32, "kernel_size": 3, "strides": 2, "padding": 0}]
    assert network["cnn"]["activation"] == "elu" and network["cnn"]["permute_input"]
    # an image encoder goes straight to the heads: fcnet_hiddens is not used, head_fcnet_hiddens is each stream's
    assert network["mlp"]["units"] == [] and network["head"]["units"] == [64]
    assert network["head"]["activation"] == "relu"  # head_fcnet_activation's default
    for model, key in (({}, "conv_filters.*image observations"),
                       ({"conv_filters": [[16, [4, 3], 2]]}, r"conv_filters\[0\].*square"),
                       ({"conv_filters": [[16, 4, 2, "full"]]}, "padding 'full'")):
        with pytest.raises(ConfigError, match=key) as info:
            networks.actor_critic_network(PPOConfig().rl_module(model_config=model), IMAGE, False)
        assert "\n" not in str(info.value)
    with pytest.raises(ConfigError, match="convolutions take images"):
        networks.actor_critic_network(PPOConfig().rl_module(model_config={"conv_filters": [[8, 3, 1]]}), FLAT, False)


def test_head_layers_are_each_streams_own_with_their_own_activation():
    # RLlib's mujoco_ppo.py: tanh encoder, a head of 256 with no activation, separate value layers
    c = PPOConfig().rl_module(model_config={"fcnet_hiddens": [256, 256], "fcnet_activation": "tanh",
                                            "head_fcnet_hiddens": [256], "head_fcnet_activation": None,
                                            "vf_share_layers": False, "free_log_std": True})
    network, _ = networks.actor_critic_network(c, FLAT, True)
    assert network["mlp"]["units"] == [256, 256] and network["mlp"]["activation"] == "tanh" and network["separate"]
    assert network["head"]["units"] == [256] and network["head"]["activation"] == "None"
    # the heads follow the LSTM (RLlib: encoder, LSTM, then the pi and vf heads)
    c = PPOConfig().rl_module(model_config={"fcnet_hiddens": [64], "head_fcnet_hiddens": [32], "use_lstm": True,
                                            "vf_share_layers": True})
    network, _ = networks.actor_critic_network(c, FLAT, False)
    assert network["mlp"]["units"] == [64] and network["head"] == {"units": [32], "activation": "relu",
                                                                   "initializer": {"name": "default"}}
    assert "head" not in networks.actor_critic_network(PPOConfig(), FLAT, False)[0]
    bad = PPOConfig().rl_module(model_config={"head_fcnet_hiddens": [32], "head_fcnet_activation": "tahn"})
    with pytest.raises(ConfigError, match="model_config.head_fcnet_activation") as info:
        networks.actor_critic_network(bad, FLAT, False)
    assert "\n" not in str(info.value)


def test_env_runners_are_ray_actors_only_when_ray_was_asked_for(monkeypatch):
    c = PPOConfig().env_runners(num_env_runners=3, num_envs_per_env_runner=2).fault_tolerance(
        restart_failed_env_runners=True, max_num_env_runner_restarts=5)
    monkeypatch.setattr(env_runners, "ray_requested", lambda: False)
    assert env_runners.env_runner_keys(c, "PPO") == {}
    assert translate.ppo_config(c, "CartPole-v1", False, {}, FLAT)["params"]["config"]["num_actors"] == 6
    monkeypatch.setattr(env_runners, "ray_requested", lambda: True)
    keys = env_runners.env_runner_keys(c, "PPO")
    assert keys == {"vecenv_type": "RAY", "env_runners": {"num_workers": 3, "envs_per_worker": 2, "max_restarts": 5}}
    assert env_runners.env_runner_keys(PPOConfig().env_runners(num_env_runners=0), "PPO") == {}
    no_restart = c.copy().fault_tolerance(restart_failed_env_runners=False)
    assert env_runners.env_runner_keys(no_restart, "PPO")["env_runners"]["max_restarts"] == 0
    cfg = vtrace_config(APPOConfig(), "CartPole-v1", FLAT, False, {})["params"]["config"]
    assert cfg["appo"]["runners"] == "ray"


def test_ray_requested_follows_ray_init_or_ray_address(monkeypatch):
    monkeypatch.setenv("RAY_ADDRESS", "auto")
    assert env_runners.ray_requested()
    monkeypatch.delenv("RAY_ADDRESS")
    ray = pytest.importorskip("ray")
    assert env_runners.ray_requested() == ray.is_initialized()


def test_a_ray_worker_steps_its_envs_in_process(monkeypatch):
    """Inside a Tune trial (a Ray worker) the trial's resources hold no CPUs for env-runner actors: the envs are
    stepped in the trial's process, even with RAY_ADDRESS set; the driver that called ray.init() gets actors."""
    ray = pytest.importorskip("ray")
    mode = {"value": ray.WORKER_MODE}
    context = type("Context", (), {"worker": type("Worker", (), {"mode": property(lambda self: mode["value"])})()})
    monkeypatch.setattr(ray, "is_initialized", lambda: True)
    monkeypatch.setattr(ray, "get_runtime_context", lambda: context())
    monkeypatch.setenv("RAY_ADDRESS", "auto")
    c = PPOConfig().env_runners(num_env_runners=2)
    assert not env_runners.ray_requested() and env_runners.env_runner_keys(c, "PPO") == {}
    assert vtrace_config(APPOConfig(), "CartPole-v1", FLAT, False, {})["params"]["config"]["appo"]["runners"] == "local"
    mode["value"] = ray.SCRIPT_MODE
    assert env_runners.ray_requested() and env_runners.env_runner_keys(c, "PPO")["vecenv_type"] == "RAY"


def test_default_model_config_dataclass_carries_lstm_and_convolutions():
    from rlchain.rllib.core.rl_module.default_model_config import DefaultModelConfig

    c = PPOConfig().rl_module(model_config=DefaultModelConfig(use_lstm=True, lstm_cell_size=16, max_seq_len=10,
                                                              fcnet_hiddens=[8]))
    network, seq_len = networks.actor_critic_network(c, FLAT, False)
    assert network["rnn"]["units"] == 16 and seq_len == 10
    image = PPOConfig().rl_module(model_config=DefaultModelConfig(conv_filters=[[8, 3, 1]]))
    assert networks.actor_critic_network(image, IMAGE, False)[0]["cnn"]["convs"][0]["filters"] == 8
