"""RLlib's AlgorithmConfig on the face (rlchain.rllib.config, keys, translate): RLlib's names and defaults, the
builders, old-stack names, one-line errors, and the one translation onto rlchain's PPO keys."""

import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib import translate
from rlchain.rllib.algorithm import CHECKPOINT_FILE, checkpoint_file
from rlchain.rllib.algorithms.ppo import PPO, PPOConfig
from rlchain.rllib.core.rl_module.default_model_config import DefaultModelConfig
from rlchain.runs.checkpoint import CheckpointError


def _params(config, continuous=False):
    return translate.ppo_config(config, "CartPole-v1", continuous, {})["params"]


def test_ppo_defaults_are_rllibs():
    c = PPOConfig()
    assert (c.lr, c.train_batch_size, c.minibatch_size, c.num_epochs, c.gamma, c.lambda_) == \
        (5e-5, 4000, 128, 30, 0.99, 1.0)
    assert (c.clip_param, c.vf_clip_param, c.kl_coeff, c.kl_target, c.entropy_coeff, c.vf_loss_coeff) == \
        (0.3, 10.0, 0.2, 0.01, 0.0, 1.0)
    assert c.grad_clip is None and c.use_kl_loss and c.num_env_runners == 2
    assert c.model_config["fcnet_hiddens"] == [256, 256] and c.model_config["vf_share_layers"] is False
    assert c.algo_class is PPO  # as in RLlib (test_rllib_algorithm_class)


def test_builders_chain_and_old_names_set_the_new_keys():
    c = (PPOConfig().environment("CartPole-v1", env_config={"a": 1}).framework("torch")
         .rollouts(num_rollout_workers=3).training(num_sgd_iter=7, sgd_minibatch_size=64, lambda_=0.9)
         .resources(num_gpus=0).reporting(metrics_num_episodes_for_smoothing=20).debugging(seed=3)
         .api_stack(enable_rl_module_and_learner=True).fault_tolerance(restart_failed_env_runners=True)
         .learners(num_learners=0).evaluation(evaluation_interval=2))
    assert (c.env, c.env_config, c.num_env_runners, c.num_epochs, c.minibatch_size, c["lambda"]) == \
        ("CartPole-v1", {"a": 1}, 3, 7, 64, 0.9)
    assert c.get("seed") == 3 and c.get("no_such_key", "x") == "x" and c.num_sgd_iter == 7


def test_unknown_key_is_one_line_with_a_did_you_mean():
    with pytest.raises(ConfigError, match=r"PPOConfig.training\(\): lrr: not an RLlib config key; did you mean 'lr'"
                       ) as info:
        PPOConfig().training(lrr=1e-3)
    assert "\n" not in str(info.value)
    with pytest.raises(ConfigError, match=r"num_env_runners: .*belongs to .env_runners\(\)"):
        PPOConfig().training(num_env_runners=2)
    with pytest.raises(ConfigError, match="kl_coef.*did you mean 'kl_coeff'"):
        PPOConfig().update_from_dict({"kl_coef": 0.1})


def test_to_dict_update_from_dict_and_copy_round_trip():
    c = PPOConfig().environment("CartPole-v1").training(lr=1e-3, lambda_=0.95)
    d = c.to_dict()
    assert d["lr"] == 1e-3 and d["lambda"] == 0.95 and "lambda_" not in d and d["train_batch_size"] == 4000
    other = PPOConfig().update_from_dict(d)
    assert other.to_dict() == d
    copied = c.copy()
    copied.training(lr=5.0)
    assert c.lr == 1e-3 and copied.lr == 5.0
    c.lr = 2e-3  # attribute assignment, as RLlib scripts do
    assert c.lr == 2e-3


def test_model_config_from_default_model_config_and_old_model_dict():
    c = PPOConfig().rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[32], fcnet_activation="linear",
                                                              vf_share_layers=True))
    network = _params(c)["network"]
    assert network["mlp"]["units"] == [32] and network["mlp"]["activation"] == "None" and not network["separate"]
    old = PPOConfig().training(model={"fcnet_hiddens": [64, 64], "fcnet_activation": "relu"})
    network = _params(old)["network"]
    assert network["mlp"] == {"units": [64, 64], "activation": "relu", "initializer": {"name": "default"}}
    assert network["separate"]  # PPO's default: no shared value layers


def test_translation_maps_rllibs_meaning():
    c = PPOConfig().training(lr=3e-4, num_epochs=6, vf_loss_coeff=0.01, grad_clip=0.5, use_gae=False)
    cfg = _params(c)["config"]
    # 2 envs, 4000 steps: exactly RLlib's batch, in RLlib's cyclic minibatches of 128 over its batch's rows
    # (its masked bootstrap rows in the order and in the advantages' standardization: rlchain.algos.ppo.rllib_batch)
    assert (cfg["num_actors"], cfg["horizon_length"], cfg["minibatch_size"], cfg["mini_epochs"]) == (2, 2000, 128, 6)
    assert (cfg["minibatch_order"], cfg["advantage_normalization"]) == ("rllib", "rllib")
    fixed = _params(PPOConfig().training(shuffle_batch_per_epoch=False))["config"]  # whole minibatches, in order
    assert (fixed["minibatch_size"], fixed["minibatch_order"]) == (125, "fixed")
    assert cfg["critic_coef"] == pytest.approx(0.02)  # rlchain's value loss is 0.5 * critic_coef * MSE
    assert (cfg["kl_loss_coef"], cfg["kl_loss_target"], cfg["value_loss_clip"]) == (0.2, 0.01, 10.0)
    assert (cfg["e_clip"], cfg["tau"], cfg["learning_rate"], cfg["lr_schedule"]) == (0.3, 1.0, 3e-4, None)
    assert cfg["grad_norm"] == 0.5 and cfg["truncate_grads"] and cfg["kl_reference"] == "rollout"
    assert not cfg["clip_value"] and cfg["reward_shaper"] == {"scale_value": 1.0}
    off = _params(PPOConfig().training(use_kl_loss=False, grad_clip=None))["config"]
    assert off["kl_loss_coef"] == 0.0 and off["kl_loss_target"] is None and not off["truncate_grads"]
    assert not cfg["compile_update"]
    compiled = _params(PPOConfig().framework("torch", torch_compile_learner=True))["config"]
    assert compiled["compile_update"]  # RLlib's compiled learner: rlchain's compiled minibatch step
    multi = translate.ppo_config(PPOConfig().framework("torch", torch_compile_learner=True), "CartPole-v1", False, {},
                                 rllib_batch=False)["params"]["config"]
    assert not multi["compile_update"]  # the multi-agent face's base: rlchain's multi-policy PPO trains eager


@pytest.mark.parametrize("batch, envs, minibatch, steps", [(4000, 2, 128, 2048), (4000, 64, 128, 64),
                                                           (1000, 3, 100, 400), (128, 1, 128, 128)])
def test_horizon_holds_the_batch_in_whole_minibatches(batch, envs, minibatch, steps):
    assert translate.horizon(batch, envs, minibatch) == steps
    assert envs * steps >= batch and envs * steps % minibatch == 0


@pytest.mark.parametrize("batch, envs, minibatch, shape", [(4000, 2, 128, (2000, 125)), (4000, 64, 128, (63, 126)),
                                                           (1000, 4, 100, (250, 100)), (4000, 3, 128, (1334, 138)),
                                                           (1024, 40, 128, (26, 130)), (256, 1, 64, (256, 64)),
                                                           (100, 1, 500, (100, 100)), (4001, 1, 128, (4096, 128))])
def test_batch_shape_samples_what_rllib_samples(batch, envs, minibatch, shape):
    """The epoch is RLlib's rollout fragment on every env (RLlib's tuned Pendulum: 26 steps of 40 envs, 1,040),
    split into the whole minibatches nearest RLlib's size; a batch with no divisor near it rounds up instead."""
    steps, size = translate.batch_shape(batch, envs, minibatch)
    assert (steps, size) == shape
    assert (envs * steps) % size == 0


@pytest.mark.parametrize("batch, envs, fragment, steps", [(1024, 40, "auto", 26), (4000, 2, "auto", 2000),
                                                          (1000, 3, "auto", 334), (1000, 4, 100, 300),
                                                          (1000, 2, 500, 500), (10, 40, "auto", 1)])
def test_fragment_length_is_rllibs(batch, envs, fragment, steps):
    """RLlib 2.60's get_rollout_fragment_length ("auto": the batch over the envs, the longer fragment where it
    does not divide) and its sampling of whole rounds of an explicit fragment until the batch is in."""
    assert translate.fragment_length(batch, envs, fragment) == steps


def test_tuned_pendulum_samples_rllibs_1040_env_steps():
    config = (PPOConfig().environment("Pendulum-v1")
              .env_runners(num_env_runners=2, num_envs_per_env_runner=20)
              .training(train_batch_size_per_learner=1024, minibatch_size=128))
    cfg = _params(config)["config"]
    assert (cfg["num_actors"], cfg["horizon_length"], cfg["minibatch_size"]) == (40, 26, 128)


@pytest.mark.parametrize("build, key", [
    (lambda c: c.framework("tf2"), "framework"),
    (lambda c: c.training(learner_class=object), "learner_class"),
    (lambda c: c.learners(num_learners=2), "num_learners"),
    (lambda c: c.rl_module(model_config={"use_attention": True}), "model_config.use_attention"),
    (lambda c: c.rl_module(model_config={"fcnet_hidens": [8]}), "model_config.fcnet_hidens"),
    (lambda c: c.training(grad_clip=1.0, grad_clip_by="value"), "grad_clip_by"),
    (lambda c: c.training(entropy_coeff_schedule=[[0, 0.01]]), "entropy_coeff_schedule"),
])
def test_what_the_face_does_not_offer_is_one_line(build, key):
    with pytest.raises(ConfigError, match=key) as info:
        build(PPOConfig()).validate()
    assert "\n" not in str(info.value)


def test_built_config_is_frozen():
    c = PPOConfig()
    c.freeze()
    with pytest.raises(ConfigError, match="frozen"):
        c.training(lr=1.0)
    assert c.copy().training(lr=1.0).lr == 1.0


def test_rllib_checkpoints_are_refused_without_unpickling(tmp_path):
    (tmp_path / "algorithm_state.pkl").write_bytes(b"\x80\x04not read")
    with pytest.raises(CheckpointError, match="an RLlib checkpoint .*does not unpickle") as info:
        checkpoint_file(tmp_path)
    assert "\n" not in str(info.value)
    ours = tmp_path / "ours"
    ours.mkdir()
    (ours / CHECKPOINT_FILE).write_bytes(b"")
    assert checkpoint_file(ours) == str(ours / CHECKPOINT_FILE)


def test_dqn_config_maps_onto_rlchains_dqn():
    from rlchain.rllib.algorithms.dqn import DQNConfig

    c = (DQNConfig().env_runners(num_env_runners=2, num_envs_per_env_runner=2)
         .training(train_batch_size=64, training_intensity=128, n_step=3, epsilon=[(0, 1.0), (5000, 0.02)],
                   target_network_update_freq=800, replay_buffer_config={"type": "EpisodeReplayBuffer",
                                                                         "capacity": 20000}))
    assert c.lr == 5e-4 and c.dueling and c.double_q and c.hiddens == [256]
    params = translate.dqn_config(c, "CartPole-v1", {})["params"]
    cfg = params["config"]
    # RLlib's calculate_rr_weights: native ratio 64 / (fragment 3 (auto: n_step) x 2 envs x (2 + 1) runners),
    # 128 / 3.56 = 36 updates after each sampled round of 3 vector steps of the 4 envs; the target every 800 env
    # steps = 200 vector steps = 2400 updates
    assert (cfg["num_actors"], cfg["num_updates_per_step"], cfg["update_every"]) == (4, 36, 3)
    assert cfg["target_update_frequency"] == 2400
    assert (cfg["epsilon_start"], cfg["epsilon_end"], cfg["epsilon_decay_frames"]) == (1.0, 0.02, 5000)
    assert cfg["n_step"] == 3 and cfg["replay_buffer_size"] == 20000 and not cfg["prioritized_replay"]
    assert cfg["num_steps_per_episode"] == 250  # min_sample_timesteps_per_iteration 1000 over 4 envs
    # RLlib 2.60's DQN module: the encoder of fcnet_hiddens, then per stream head_fcnet_hiddens ([]: a linear
    # layer); hiddens ([256]) is the old stack's and builds nothing
    assert params["network"]["mlp"]["units"] == [256, 256] and params["network"]["dueling"]
    assert "head" not in params["network"]
    heads = translate.dqn_config(c.copy().rl_module(model_config={"fcnet_hiddens": [64], "fcnet_activation": "tanh",
                                                                  "head_fcnet_hiddens": [32]}), "CartPole-v1", {})
    assert heads["params"]["network"]["mlp"]["units"] == [64] and heads["params"]["network"]["mlp"]["activation"] \
        == "tanh"
    assert heads["params"]["network"]["head"]["units"] == [32] and heads["params"]["network"]["head"]["activation"] \
        == "relu"  # head_fcnet_activation's default
    # RLlib's new-stack name for the batch wins over train_batch_size, in the batch and in the replay ratio
    per_learner = translate.dqn_config(c.copy().training(train_batch_size_per_learner=16), "CartPole-v1", {})
    assert (per_learner["params"]["config"]["batch_size"], per_learner["params"]["config"]["num_updates_per_step"]) \
        == (16, 144)  # native ratio 16 / 18; 128 / 0.89 = 144 updates per round of 3 vector steps
    # no training_intensity: one update per sampled round, here rollout_fragment_length 4 vector steps
    plain = translate.dqn_config(DQNConfig().env_runners(rollout_fragment_length=4), "CartPole-v1", {})
    assert (plain["params"]["config"]["num_updates_per_step"], plain["params"]["config"]["update_every"]) == (1, 4)
    # fewer updates than rounds: native ratio 32 / (1 step x 1 env, the local runner) = 32; 5 / 32 -> one update
    # after every 6 rounds of 1 vector step
    sparse = translate.dqn_config(DQNConfig().training(train_batch_size=32, training_intensity=5), "CartPole-v1", {})
    assert (sparse["params"]["config"]["num_updates_per_step"], sparse["params"]["config"]["update_every"]) == (1, 6)
    with pytest.raises(ConfigError, match="num_atoms.*distributional"):
        translate.dqn_config(DQNConfig().training(num_atoms=51), "CartPole-v1", {})


def test_unoffered_algorithms_are_one_line():
    from rlchain.rllib import envs
    from rlchain.rllib.algorithms.dqn import DQNConfig

    with pytest.raises(ConfigError, match="Box actions are not mapped by the face for DQN") as info:
        DQNConfig().environment("Pendulum-v1").build_algo()
    assert "\n" not in str(info.value)
    with pytest.raises(ConfigError, match="'CartPol-v1' is neither a gymnasium id.*did you mean 'CartPole-v1'"):
        envs.env_maker("CartPol-v1", {}, 0, 1)


def test_env_context_carries_env_config_and_where_the_env_runs():
    from rlchain.rllib import envs

    made = []
    with pytest.raises(ConfigError, match="expected a gymnasium id, a registered env name or an env class"):
        envs.env_maker(lambda ctx: ctx, {"size": 3}, 2, 2)  # as RLlib: a name or a class, not a function
    make, _ = envs.env_maker(type("E", (), {"__init__": lambda self, ctx: made.append(ctx)}), {"size": 3}, 2, 2)
    make(3)
    ctx = made[-1]
    assert dict(ctx) == {"size": 3} and (ctx.worker_index, ctx.vector_index, ctx.num_workers) == (2, 1, 2)


def test_experimental_keys_are_kept_and_learner_side_torch_schedulers_refused_in_one_line():
    from rlchain.rllib.algorithms.ppo import PPOConfig as Config

    config = Config().experimental(_validate_config=False, _disable_preprocessor_api=True)
    assert config._validate_config is False and config["_disable_preprocessor_api"] is True
    config.validate()
    with pytest.raises(ConfigError, match="_torch_lr_scheduler_classes.*schedule list") as info:
        Config().experimental(_torch_lr_scheduler_classes=[object()]).validate()
    assert "\n" not in str(info.value)


def test_default_model_config_takes_every_field_rllibs_has_with_rllibs_defaults():
    # RLlib's tuned examples pass the initializer and fusion-net fields (cartpole_dqn.py: head_fcnet_bias_initializer;
    # pendulum_sac.py: fusionnet_hiddens): each is a field, with RLlib 2.60's default
    import dataclasses

    from rlchain.rllib import keys as K
    fields = {f.name: getattr(DefaultModelConfig(), f.name) for f in dataclasses.fields(DefaultModelConfig)}
    assert fields == K.DEFAULT_MODEL
    model = DefaultModelConfig(fcnet_hiddens=[16], head_fcnet_bias_initializer="zeros_", fusionnet_hiddens=[8],
                               lstm_kernel_initializer="xavier_uniform_", head_fcnet_kernel_initializer_kwargs={})
    net = _params(PPOConfig().rl_module(model_config=model))["network"]
    assert net["mlp"]["units"] == [16]  # the initializers and the fusion net are kept with no effect
