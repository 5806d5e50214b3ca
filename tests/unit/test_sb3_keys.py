"""rlchain.sb3.keys: Stable-Baselines3's argument names -> rlchain's config keys (pure, no env, no torch)."""

import re

import pytest

from rlchain.config.errors import ConfigError
from rlchain.sb3.keys import activation_name, build_config, multi_input_block, run_name

PPO_KEYS = ["horizon_length", "minibatch_size", "kl_threshold", "num_actors", "learning_rate"]


def ppo(given, num_actors=8, continuous=False, **kw):
    return build_config("ppo", "CartPole-v1", num_actors, continuous, given, PPO_KEYS, **kw)["params"]


def test_ppo_names_map_to_rl_games_keys():
    cfg = ppo({"n_steps": 64, "batch_size": 128, "n_epochs": 10, "gamma": 0.98, "gae_lambda": 0.8,
               "clip_range": 0.1, "ent_coef": 0.01, "vf_coef": 0.5, "max_grad_norm": 0.5, "learning_rate": 3e-4,
               "clip_range_vf": None})["config"]
    assert (cfg["horizon_length"], cfg["minibatch_size"], cfg["mini_epochs"]) == (64, 128, 10)
    assert (cfg["gamma"], cfg["tau"], cfg["e_clip"], cfg["entropy_coef"]) == (0.98, 0.8, 0.1, 0.01)
    assert cfg["critic_coef"] == 1.0  # rlchain's value loss is 0.5 * critic_coef * mse; SB3's vf_coef * mse
    assert cfg["grad_norm"] == 0.5 and cfg["truncate_grads"] is True
    assert cfg["learning_rate"] == 3e-4 and cfg["lr_schedule"] is None  # SB3's learning rate is constant
    assert cfg["clip_value"] is False


def test_rlchain_defaults_fit_the_env_count():
    cfg = ppo({}, num_actors=3, defaults="rlchain")["config"]
    batch = 3 * cfg["horizon_length"]
    assert batch >= 512 and batch % cfg["minibatch_size"] == 0 and cfg["minibatch_size"] <= 256
    assert ppo({}, num_actors=32, defaults="rlchain")["config"]["horizon_length"] == 16


def test_rlchain_defaults_are_the_packaged_examples_settings():
    """defaults='rlchain' reads rlchain/configs/<example>.yaml: its settings, not its env and run keys."""
    from rlchain.config.packaged import config_names
    from rlchain.config.text import read_data

    for algo, continuous, example in (("ppo", False, "ppo_cartpole"), ("ppo", True, "ppo_pendulum"),
                                      ("sac", True, "sac_pendulum"), ("dqn", False, "dqn_cartpole")):
        params = build_config(algo, "Env-v0", 4, continuous, {}, [], defaults="rlchain")["params"]
        packaged = read_data(config_names()[example])["params"]
        assert params["network"] == packaged["network"], example
        assert params["config"]["gamma"] == packaged["config"]["gamma"]
        assert params["config"]["save_best_after"] == packaged["config"]["save_best_after"]
        assert params["config"]["env_name"] == "Env-v0" and params["config"]["num_actors"] == 4
        assert "score_to_win" not in params["config"] and "player" not in params["config"]
    sac = build_config("sac", "Env-v0", 4, True, {}, [], defaults="rlchain")["params"]["config"]
    assert sac["actor_lr"] == 3e-4 and isinstance(sac["actor_lr"], float)  # the YAML's '3e-4', a number


def test_sb3_defaults_are_sb3s_algorithm():
    params = ppo({}, num_actors=1)
    cfg = params["config"]
    assert (cfg["horizon_length"], cfg["minibatch_size"], cfg["mini_epochs"]) == (2048, 64, 10)
    assert (cfg["learning_rate"], cfg["lr_schedule"], cfg["gamma"], cfg["tau"]) == (3e-4, None, 0.99, 0.95)
    assert cfg["critic_coef"] == 1.0 and cfg["grad_norm"] == 0.5 and cfg["clip_value"] is False  # vf_coef 0.5
    assert "reward_shaper" not in cfg and cfg["normalize_input"] is False and cfg["normalize_value"] is False
    assert params["network"]["separate"] is True and params["network"]["mlp"]["units"] == [64, 64]
    continuous = ppo({}, num_actors=1, continuous=True)
    assert continuous["config"]["normalize_input"] is False and continuous["config"]["bounds_loss_coef"] == 0.0
    assert "continuous" in continuous["network"]["space"]
    sac = build_config("sac", "Pendulum-v1", 1, True, {}, [])["params"]["config"]
    assert (sac["batch_size"], sac["replay_buffer_size"], sac["num_warmup_frames"]) == (256, 1_000_000, 100)
    dqn = build_config("dqn", "CartPole-v1", 1, False, {}, [], total_timesteps=50_000)["params"]["config"]
    assert dqn["epsilon_decay_frames"] == 5_000 and dqn["double_dqn"] is False and dqn["target_tau"] == 1.0


def test_defaults_takes_sb3_or_rlchain():
    with pytest.raises(ConfigError, match=r"^rlchain.PPO: defaults: expected one of sb3, rlchain, got 'sb2'"):
        ppo({}, defaults="sb2")


def test_rlchain_keys_pass_through_and_policy_kwargs_map():
    params = ppo({"kl_threshold": 0.02}, policy_kwargs={"net_arch": {"pi": [32], "vf": [32]},
                                                          "activation_fn": "ReLU"})
    assert params["config"]["kl_threshold"] == 0.02
    assert params["network"]["mlp"]["units"] == [32] and params["network"]["mlp"]["activation"] == "relu"
    assert params["network"]["separate"] is True


def test_separate_actor_and_critic_sizes_give_the_critic_its_own_mlp():
    params = ppo({}, policy_kwargs={"net_arch": {"pi": [64, 64], "vf": [32]}, "activation_fn": "ReLU"})
    assert params["network"]["mlp"]["units"] == [64, 64]
    assert params["network"]["critic_mlp"]["units"] == [32] and params["network"]["critic_mlp"]["activation"] == "relu"


def test_continuous_ppo_and_log_std_init():
    params = ppo({}, continuous=True, policy_kwargs={"log_std_init": -0.5})
    assert params["algo"]["name"] == "a2c_continuous"
    assert params["network"]["space"]["continuous"]["sigma_init"]["val"] == -0.5


@pytest.mark.parametrize(("given", "policy_kwargs", "says"), [
    ({"n_step": 8}, None, "n_step: unknown argument; did you mean 'n_steps'?"),
    ({"target_kl": 0.01}, None, "target_kl: has no rlchain counterpart"),
    ({"learning_rate": lambda p: 1e-3}, None, "learning_rate: expected a number"),
    ({}, {"net_arch": {"pi": [64], "qf": [32]}}, "expected the keys pi and vf"),
    ({}, {"netarch": [64]}, "did you mean 'net_arch'?"),
])
def test_bad_arguments_are_one_line_errors(given, policy_kwargs, says):
    with pytest.raises(ConfigError) as err:
        ppo(given, policy_kwargs=policy_kwargs)
    assert says in str(err.value) and "\n" not in str(err.value) and str(err.value).startswith("rlchain.PPO: ")


def test_off_policy_names():
    sac = build_config("sac", "Pendulum-v1", 4, True, {"buffer_size": 5000, "learning_starts": 100, "tau": 0.01,
                                                      "learning_rate": 1e-3, "ent_coef": "auto_0.1",
                                                      "train_freq": 2, "gradient_steps": 4}, [])["params"]["config"]
    assert (sac["replay_buffer_size"], sac["num_warmup_frames"], sac["critic_tau"]) == (5000, 100, 0.01)
    assert sac["actor_lr"] == sac["critic_lr"] == sac["alpha_lr"] == 1e-3
    assert sac["learnable_temperature"] is True and sac["init_alpha"] == 0.1
    assert (sac["num_updates_per_step"], sac["update_every"]) == (4, 2)  # 4 updates after every 2nd step, as SB3
    dqn = build_config("dqn", "CartPole-v1", 4, False, {"exploration_fraction": 0.1, "target_update_interval": 500,
                                                        "tau": 1.0, "gradient_steps": -1}, [],
                       total_timesteps=100_000)["params"]["config"]
    assert dqn["epsilon_decay_frames"] == 10_000 and dqn["target_update_frequency"] == 500
    # gradient_steps -1 with DQN's train_freq 4: as many updates as env steps since the last round, 4 x 4 envs
    assert dqn["target_tau"] == 1.0 and (dqn["num_updates_per_step"], dqn["update_every"]) == (16, 4)
    assert dqn["max_frames"] == 100_000
    sparse = build_config("sac", "Pendulum-v1", 1, True, {"train_freq": 4, "gradient_steps": 1}, [])
    assert (sparse["params"]["config"]["num_updates_per_step"], sparse["params"]["config"]["update_every"]) == (1, 4)
    default_dqn = build_config("dqn", "CartPole-v1", 1, False, {}, [])["params"]["config"]
    assert (default_dqn["num_updates_per_step"], default_dqn["update_every"]) == (1, 4)  # SB3's DQN defaults
    for given, says in [({"train_freq": (4, "episode")}, "only (n, 'step') maps"),
                        ({"train_freq": 0}, "train_freq: expected an int >= 1, got 0"),
                        ({"gradient_steps": 0}, "gradient_steps: expected an int >= 1 or -1, got 0")]:
        with pytest.raises(ConfigError, match=re.escape(says)) as err:
            build_config("dqn", "CartPole-v1", 1, False, given, [])
        assert "\n" not in str(err.value)


def test_sac_clip_mean_is_the_networks_mean_clip():
    sac = build_config("sac", "Pendulum-v1", 1, True, {}, [], policy_kwargs={"clip_mean": 2.0})["params"]
    assert sac["network"]["mean_clip"] == 2.0
    assert build_config("sac", "Pendulum-v1", 1, True, {}, [], policy_kwargs={"clip_mean": 0})["params"][
        "network"]["mean_clip"] is None  # SB3: 0 is no clip
    with pytest.raises(ConfigError, match=r"^rlchain.SAC: policy_kwargs.clip_mean: expected a number >= 0 "
                                          r"\(0: no clip\), got 'big'$"):
        build_config("sac", "Pendulum-v1", 1, True, {}, [], policy_kwargs={"clip_mean": "big"})
    with pytest.raises(ValueError, match="policy_kwargs: unknown key 'clip_mean'"):
        ppo({}, policy_kwargs={"clip_mean": 2.0})


def test_names():
    assert run_name("ppo", "CartPole-v1") == "ppo_cartpole" and run_name("sac", "ALE/Pong-v5") == "sac_pong"
    assert activation_name(type("Tanh", (), {})) == "tanh"
    with pytest.raises(ValueError, match="no rl_games activation"):
        activation_name("Mish")


def test_multi_input_block_for_sac_and_dqn():
    sac = build_config("sac", "Env-v0", 1, True, {}, [])["params"]
    multi_input_block("sac", sac, "multi_input")
    assert sac["network"]["name"] == "multi_input" and "log_std_bounds" not in sac["network"]
    assert sac["config"]["log_std_bounds"] == [-20, 2]  # SB3's bounds, now the config's key
    dqn = build_config("dqn", "Env-v0", 1, False, {}, [])["params"]
    multi_input_block("dqn", dqn, "multi_input")
    assert dqn["network"]["name"] == "multi_input" and dqn["network"]["dueling"] is False  # SB3's DQN head
    gsde = build_config("sac", "Env-v0", 1, True, {}, [], policy_kwargs={"clip_mean": 2.0})["params"]
    with pytest.raises(ConfigError, match="policy_kwargs.clip_mean: not supported with MultiInputPolicy"):
        multi_input_block("sac", gsde, "multi_input")
