"""rl_games 2.0's config keys: each parses with its meaning, or is a one-line ConfigError naming the key."""

import copy
import math

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.algos.core.schedules import AdaptiveKLSchedule
from rlchain.config import ConfigError, parse_params
from rlchain.config.run import amp_dtype_name
from rlchain.models.build import build_model
from rlchain.models.distributions import DiagGaussian

CONTINUOUS = {"mu_activation": "None", "sigma_activation": "None", "mu_init": {"name": "default"},
              "sigma_init": {"name": "const_initializer", "val": 0}, "fixed_sigma": True}


def parse(cfg):
    return parse_params(cfg, "cfg.yaml")


def continuous_config(base, **space):
    cfg = copy.deepcopy(base)
    cfg["params"]["algo"]["name"] = "a2c_continuous"
    cfg["params"]["model"]["name"] = "continuous_a2c_logstd"
    cfg["params"]["network"]["space"] = {"continuous": {**CONTINUOUS, **space}}
    cfg["params"]["config"]["env_name"] = "Pendulum-v1"
    return cfg


def sac_config(**config):
    return {"params": {"seed": 1, "algo": {"name": "sac"}, "model": {"name": "soft_actor_critic"},
                       "network": {"name": "soft_actor_critic", "space": {"continuous": {}},
                                   "mlp": {"units": [8], "activation": "relu"}},
                       "config": {"name": "s", "env_name": "Pendulum-v1", "device": "cpu", **config}}}


BOX = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)


@pytest.mark.parametrize("kind,min_sigma,bounds,raw,expected", [
    ("exp", 0.0, None, 0.0, 1.0),
    ("exp", 0.1, None, math.log(0.5), 0.6),
    ("exp", 0.0, (-5.0, 0.5), 2.0, math.exp(0.5)),  # clamped to logstd_bounds
    ("softplus", 0.2, None, 0.0, math.log(2.0) + 0.2),
    ("linear", 0.0, None, 1.0, 1e-3 + math.log1p(math.exp(1.0 - 1e-3))),  # floor 1e-3
    ("linear", 0.15, None, 0.15, 0.15 + math.log(2.0)),
])
def test_sigma_parametrizations_match_rl_games_2(kind, min_sigma, bounds, raw, expected):
    dist = DiagGaussian(BOX, sigma_is_logstd=True, clip_actions=True, parametrization=kind, min_sigma=min_sigma,
                        logstd_bounds=bounds)
    std = dist.std_of(torch.full((1, 2), raw))
    assert std[0, 0].item() == pytest.approx(expected, rel=1e-5)
    if bounds is None:  # --sigma: the raw value whose std is the one asked for
        assert dist.std_of(torch.tensor(dist.raw_sigma(0.8))).item() == pytest.approx(0.8, rel=1e-5)


def test_sigma_parametrization_reaches_the_model(base_config):
    params = parse(continuous_config(base_config, sigma_parametrization="scalar", min_sigma=0.2))
    env = gym.make("Pendulum-v1")
    model = build_model(params, env, torch.device("cpu"))
    assert model.dist.parametrization == "linear" and model.dist.min_sigma == 0.2
    params_out, _ = model(torch.zeros(3, 3))
    std = params_out[:, 1:]
    assert torch.all(std > 0.2)  # the floor holds for any raw sigma
    model.override_sigma(0.5)
    assert model(torch.zeros(1, 3))[0][0, 1].item() == pytest.approx(0.5, rel=1e-5)


@pytest.mark.parametrize("space,expect", [
    ({"sigma_parametrization": "cubic"}, "not one of"),
    ({"min_sigma": -0.1}, "must be >= 0"),
    ({"logstd_bounds": [2, -5]}, "low < high"),
])
def test_bad_sigma_keys_name_the_key(base_config, space, expect):
    with pytest.raises(ConfigError) as err:
        parse(continuous_config(base_config, **space))
    key = next(iter(space))
    assert f"params.network.space.continuous.{key}" in str(err.value) and expect in str(err.value)


def test_sigma_parametrization_needs_the_logstd_model(base_config):
    cfg = continuous_config(base_config, sigma_parametrization="softplus")
    cfg["params"]["model"]["name"] = "continuous_a2c"
    params = parse(cfg)
    with pytest.raises(ConfigError, match="apply to model continuous_a2c_logstd"):
        build_model(params, gym.make("Pendulum-v1"), torch.device("cpu"))


@pytest.mark.parametrize("actors,ratio,updates", [(32, 1.0, 32), (32, 0.25, 8), (4, 0.01, 1)])
def test_utd_ratio_sets_updates_per_step(actors, ratio, updates):
    params = parse(sac_config(num_actors=actors, utd_ratio=ratio, num_updates_per_step=3))
    assert params.config.num_updates_per_step == updates


def test_sac_network_normalization_layer_norm():
    params = parse(sac_config(num_actors=1))
    raw = sac_config(num_actors=1)
    raw["params"]["network"]["normalization"] = "layer_norm"
    model = build_model(parse(raw), gym.make("Pendulum-v1"), torch.device("cpu"))
    norms = [name for name, m in model.named_modules() if isinstance(m, torch.nn.LayerNorm)]
    for part in ("actor.", "critic.Q1.", "critic.Q2."):  # the actor and both critics (and their targets)
        assert any(part in name for name in norms), (part, norms)
    assert params.network.normalization is None


@pytest.mark.parametrize("value,ok", [(True, True), (False, True), ("bf16", True), ("fp16", True),
                                      ("fp8", False), (1, False)])
def test_mixed_precision_values(base_config, value, ok):
    base_config["params"]["config"]["mixed_precision"] = value
    if ok:
        assert parse(base_config).config.mixed_precision == value
    else:
        with pytest.raises(ConfigError, match=r"params\.config\.mixed_precision: expected False, True, bf16 or fp16"):
            parse(base_config)


def test_mixed_precision_dtypes():
    assert amp_dtype_name(True, bf16_supported=True) == "bfloat16"  # rl_games 2.0
    assert amp_dtype_name(True, bf16_supported=False) == "float16"
    assert amp_dtype_name("fp16", bf16_supported=True) == "float16"  # rl_games 1.6 (with a GradScaler)
    assert amp_dtype_name("bf16", bf16_supported=True) == "bfloat16"
    assert amp_dtype_name(False, bf16_supported=True) is None


def test_lr_multiplier(base_config):
    schedule = AdaptiveKLSchedule(0.01, 1e-6, 1.0, lr_multiplier=2.0)
    assert schedule.update(0.1, kl=0.001) == pytest.approx(0.2)
    assert schedule.update(0.1, kl=0.05) == pytest.approx(0.05)
    base_config["params"]["config"]["lr_multiplier"] = 1.0
    with pytest.raises(ConfigError, match=r"params\.config\.lr_multiplier: .*must be > 1"):
        parse(base_config)


@pytest.mark.parametrize("key,value,expect", [
    ("multi_gpu_sync_stats", False, "False is not supported"),
    ("multi_gpu_sync_stats_mode", "broadcast", "broadcast (every rank takes rank 0's statistics) is not supported"),
    ("multi_gpu_sync_stats_mode", "mean", "expected pooled or broadcast"),
    ("stop_fn", "my.module:fn", "comes through the rl_games API"),
    ("algo_observer", "wandb", "expected one of default, isaac"),
])
def test_unsupported_2_0_values_are_one_line_errors(base_config, key, value, expect):
    base_config["params"]["config"][key] = value
    with pytest.raises(ConfigError) as err:
        parse(base_config)
    assert f"params.config.{key}" in str(err.value) and expect in str(err.value)
    assert "\n" not in str(err.value)


def test_supported_2_0_values(base_config):
    base_config["params"]["config"].update(multi_gpu_sync_stats=True, multi_gpu_sync_stats_mode="pooled",
                                           algo_observer="isaac")
    config = parse(base_config).config
    assert config.callbacks == ["rlchain.rl_games.common.algo_observer:IsaacAlgoObserver"]


def test_env_name_gymnasium_takes_env_config_env_name(base_config):
    from rlchain.models.build import build_env

    base_config["params"]["config"].update(env_name="gymnasium",
                                           env_config={"env_name": "Pendulum-v1", "use_async": False,
                                                       "flatten_obs": True, "seed": 5})
    env = build_env(parse(base_config), 2, seed=1)
    try:
        assert env.observation_space.shape == (3,) and env.num_envs == 2
        assert env.reset().shape == (2, 3)
    finally:
        env.close()


@pytest.mark.parametrize("env_name,env_config,expect", [
    ("gymnasium", {}, "params.config.env_config.env_name: is required with env_name gymnasium"),
    ("gymnasium", {"env_name": "Pendulum-v1", "use_async": "yes"}, "use_async: expected true or false"),
    ("atari_gymnasium", {}, "params.config.env_config.env_name: is required with env_name atari_gymnasium"),
    ("atari_gymnasium", {"env_name": "ALE/Pong-v5", "frameskip": 4}, "frameskip: expected 1"),
])
def test_env_name_gymnasium_errors(base_config, env_name, env_config, expect):
    from rlchain.models.build import build_env

    base_config["params"]["config"].update(env_name=env_name, env_config=env_config)
    with pytest.raises(ConfigError) as err:
        build_env(parse(base_config), 2, seed=1)
    assert expect in str(err.value) and "\n" not in str(err.value)


def test_atari_gymnasium_and_a_channels_first_preset_give_2_0s_frames(base_config):
    pytest.importorskip("ale_py")
    from rlchain.models.build import build_env

    base_config["params"]["config"].update(env_name="atari_gymnasium",
                                           env_config={"env_name": "ALE/Pong-v5", "frameskip": 1,
                                                       "use_async": False})
    preset = copy.deepcopy(base_config)
    preset["params"]["config"].update(env_name="PongNoFrameskip-v4", env_config={})
    preset["params"]["network"]["cnn"] = {"type": "conv2d", "permute_input": False, "activation": "relu",
                                          "initializer": {"name": "default"},
                                          "convs": [{"filters": 8, "kernel_size": 8, "strides": 4, "padding": 0}]}
    assert parse(preset).config.env_config == {"channels_first": True}
    preset["params"]["network"]["cnn"]["permute_input"] = True  # 1.6.5's way: channels last, untouched
    assert parse(preset).config.env_config == {}
    env = build_env(parse(base_config), 1, seed=1)
    try:
        assert env.observation_space.shape == (4, 84, 84) and env.reset().shape == (1, 4, 84, 84)
    finally:
        env.close()


def test_use_async_picks_the_backend_only_when_vecenv_type_is_unset():
    from rlchain.envs.building import gymnasium_vecenv_kind

    assert gymnasium_vecenv_kind({}, None) == "async" and gymnasium_vecenv_kind({"use_async": False}, "auto") == "sync"
    assert gymnasium_vecenv_kind({"use_async": True}, "sync") == "sync"
    with pytest.raises(ConfigError, match="use_async: expected true or false"):
        gymnasium_vecenv_kind({"use_async": "no"}, None)


def test_env_name_ray_builds_env_config_name_in_process(base_config):
    from rlchain.models.build import build_env

    base_config["params"]["config"].update(env_name="ray", env_config={"name": "Pendulum-v1"})
    env = build_env(parse(base_config), 2, seed=1)
    try:
        assert env.observation_space.shape == (3,) and env.num_envs == 2
    finally:
        env.close()
