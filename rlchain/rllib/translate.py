"""One translation: an RLlib ``AlgorithmConfig`` -> the rlchain config (``{'params': ...}``) that trains it.

What maps (PPO; docs/rllib.md has the table):

- ``train_batch_size`` env steps per ``train()``: rlchain's epoch is ``num_actors * horizon_length`` frames, with
  ``num_actors = max(1, num_env_runners) * num_envs_per_env_runner`` and the horizon RLlib's rollout fragment
  (``rollout_fragment_length`` "auto": the batch over the envs, rounded up), so the face samples what RLlib
  samples; the minibatches are RLlib's (``minibatch_order: rllib``, rlchain.algos.ppo.rllib_batch):
  ``minibatch_size`` rows at a time cycling over RLlib's train batch, its masked bootstrap rows included; with
  ``shuffle_batch_per_epoch=False`` or an LSTM they are whole instead, the divisor of that epoch nearest
  ``minibatch_size`` (RLlib's 4000 / 128: 32 of 125; its tuned Pendulum's 1,040 / 128: 8 of 130)
  (:func:`batch_shape`).
- ``num_epochs`` -> ``mini_epochs``; ``minibatch_size`` -> ``minibatch_size``; ``lr`` -> a constant
  ``learning_rate``; ``gamma``; ``lambda_`` -> ``tau`` (``use_gae=False``: 1.0, the discounted return minus the
  value, as RLlib's); ``clip_param`` -> ``e_clip``; ``vf_clip_param`` -> ``value_loss_clip``; ``vf_loss_coeff``
  -> ``critic_coef`` (x2: rlchain's value loss is 0.5 * critic_coef * MSE); ``entropy_coeff`` -> ``entropy_coef``;
  ``use_kl_loss`` / ``kl_coeff`` / ``kl_target`` -> ``kl_loss_coef`` / ``kl_loss_target`` against the rollout's
  policy; ``grad_clip`` (``grad_clip_by='global_norm'``) -> ``grad_norm``; advantages standardized over
  RLlib's train batch, its bootstrap rows included (``advantage_normalization: rllib``); no reward scaling, no
  observation or value normalization (RLlib has none by default).
- the model (:mod:`rlchain.rllib.networks`): ``fcnet_hiddens`` -> the MLP, ``head_fcnet_hiddens`` -> ``head``;
  ``conv_filters`` -> a cnn block; ``use_lstm`` -> an rnn block and ``seq_length`` (whole sequences per
  minibatch: :func:`sequence_batch_shape`); ``vf_share_layers`` False -> a separate critic; ``free_log_std`` ->
  rlchain's fixed sigma.
- the env runners (:mod:`rlchain.rllib.env_runners`): Ray actors after ``ray.init()``, else in process.

DQN is :func:`dqn_config` here; SAC, APPO and IMPALA translate in their folders (``algorithms/<name>/translate.py``).
"""

from __future__ import annotations

import math
import os
import sys
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.errors import did_you_mean
from rlchain.rllib import keys as K
from rlchain.rllib.env_runners import env_runner_keys
from rlchain.rllib.networks import activation, actor_critic_network, layer_sizes
from rlchain.rllib.obs_filter import KEY as FILTER_KEY
from rlchain.rllib.obs_filter import filter_keys

MODEL_UNSUPPORTED = {
    "use_attention": "attention: rlchain's history policy (docs/robot_learning.md)",
    "custom_model": "an RLModule through rl_module(rl_module_spec=...) is not mapped yet: register an rl_games "
                    "network (rlchain.model_builder.register_network)",
    "fcnet_use_layernorm": "layer norm in the MLP is not mapped",
    "lstm_use_prev_action": "the previous action as an LSTM input is not mapped",
    "lstm_use_prev_reward": "the previous reward as an LSTM input is not mapped",
    "post_fcnet_hiddens": "old-stack post layers are not mapped: put them in head_fcnet_hiddens",
}
"""Model settings whose non-default value is refused, with what to use instead."""

NETWORK_FEATURES = {
    "conv_filters": {"PPO", "APPO", "IMPALA"},
    "use_lstm": {"PPO", "APPO", "IMPALA"},
    "head_fcnet_hiddens": {"PPO", "APPO", "IMPALA", "SAC", "DQN"},
}
"""Model settings (beyond the MLP) each algorithm's rlchain network takes (networks.py maps them)."""

FEATURE_WHY = {
    "conv_filters": "rlchain's {algo} network is an MLP: train images with PPO, APPO or IMPALA",
    "use_lstm": "rlchain's {algo} has no recurrent policy (off-policy): train an LSTM with PPO, APPO or IMPALA",
    "head_fcnet_hiddens": "rlchain's {algo} network is one MLP: put the layers in fcnet_hiddens",
}


def _bad(config: Any, key: str, message: str) -> ConfigError:
    return ConfigError(type(config).__name__, key, message)


def check_supported(config: Any) -> None:
    """One-line errors for settings rlchain does not offer (keys.UNSUPPORTED, MODEL_UNSUPPORTED)."""
    defaults = K.defaults(config.algo_name)
    settings = config._settings
    filter_keys(config)  # env_to_module_connector: MeanStdFilter or a one-line error
    for key, why in K.UNSUPPORTED.items():
        if key == FILTER_KEY:
            continue
        value = settings.get(key, defaults.get(key))
        fine = K.UNSUPPORTED_VALUES.get(key, (defaults.get(key),))
        if value not in fine and not (value is None and None in fine):
            raise _bad(config, key, f"{value!r} is not offered by rlchain's RLlib face: {why}")
    model = config.model_config
    for key, algos in NETWORK_FEATURES.items():
        if config.algo_name not in algos and model.get(key) not in (K.DEFAULT_MODEL.get(key), None, False, []):
            raise _bad(config, f"model_config.{key}", f"{model[key]!r} is not offered: "
                                                      f"{FEATURE_WHY[key].format(algo=config.algo_name)}")
    for key, why in MODEL_UNSUPPORTED.items():
        if key in model and model[key] not in (K.DEFAULT_MODEL.get(key), None, False, []):
            raise _bad(config, f"model_config.{key}", f"{model[key]!r} is not offered: {why}")
    unknown = set(model) - set(K.DEFAULT_MODEL) - set(K.OLD_MODEL_KEYS)
    if unknown:
        key = sorted(unknown)[0]
        raise _bad(config, f"model_config.{key}", f"not an RLlib model key{did_you_mean(key, K.DEFAULT_MODEL)}")
    if settings.get("grad_clip") is not None and settings.get("grad_clip_by") != "global_norm":
        raise _bad(config, "grad_clip_by", f"{settings.get('grad_clip_by')!r}: rlchain clips the global norm "
                                           f"(grad_clip_by='global_norm')")
    learners(config)
    if settings.get("rl_module_spec") is not None and config.algo_name != "PPO":
        raise _bad(config, "rl_module_spec", f"an RLModule trains under PPO only, not {config.algo_name}: set "
                                             f"the network with model_config (fcnet_hiddens, ...)")


def learners(config: Any) -> int:
    """RLlib's ``num_learners`` (1 for 0 or 1): more than one trains data-parallel on rlchain's torch.distributed
    path (``multi_gpu``), one process per learner started by torchrun; anything else is a one-line error naming
    the command."""
    count = int(config._settings.get("num_learners") or 0)
    if count <= 1:
        return 1
    if config.algo_name != "PPO":
        raise _bad(config, "num_learners", f"{count}: several learners train PPO only (the face maps no "
                                           f"data-parallel path for {config.algo_name})")
    world = os.environ.get("WORLD_SIZE")
    if world != str(count):
        script = os.path.basename(sys.argv[0]) if sys.argv and sys.argv[0].endswith(".py") \
            and os.path.basename(sys.argv[0]) != "__main__.py" else "SCRIPT"
        raise _bad(config, "num_learners", f"{count} learners train data-parallel under torch.distributed, one "
                                           f"process each: start the script with `torchrun --standalone "
                                           f"--nproc_per_node={count} -m rlchain.rllib {script} [ARGS]`"
                                           f"{'' if world is None else f' (this launch has WORLD_SIZE={world})'}")
    return count


def num_envs(config: Any) -> int:
    """Envs stepped together: RLlib's env runners times envs per runner (the local runner when 0)."""
    settings = config._settings
    runners = max(1, int(settings.get("num_env_runners") or 0))
    return runners * max(1, int(settings.get("num_envs_per_env_runner") or 1))


def fragment_length(batch: int, envs: int, fragment: Any = "auto") -> int:
    """Steps each env samples per ``train()`` as RLlib 2.60 samples them (``get_rollout_fragment_length``).

    "auto": ``batch / envs``; where that is a fraction RLlib gives the first env runners one step more so the
    fragments add up to exactly ``batch``; rlchain's envs share one horizon, so each takes the longer fragment
    (at most ``envs - 1`` env steps over RLlib's batch). A number F: every env samples F steps per round, and
    RLlib samples rounds until ``batch`` env steps are in (``synchronous_parallel_sample``).
    """
    if fragment in (None, "auto"):
        return max(1, -(-batch // envs))
    per_round = max(1, int(fragment))
    return per_round * max(1, -(-batch // (per_round * envs)))


def batch_shape(batch: int, envs: int, minibatch: int, fragment: Any = "auto") -> tuple[int, int]:
    """(steps per env per epoch, minibatch size) for ``train_batch_size`` ``batch`` on ``envs`` envs.

    The epoch is what RLlib samples per ``train()`` (:func:`fragment_length`: RLlib's 4000 on 2 envs, 2000 steps
    each; its tuned Pendulum's 1024 on 40 envs, 26 steps each = 1,040). rlchain's minibatches are whole, so the
    minibatch is the divisor of that epoch nearest ``minibatch`` (125 for RLlib's 128 on 4,000 rows, 130 on
    1,040); where no divisor lies within a factor 2 of it, the horizon is instead rounded up to whole minibatches
    of ``minibatch`` (:func:`horizon`: more env steps than RLlib).
    """
    steps = fragment_length(batch, envs, fragment)
    total = steps * envs
    minibatch = min(minibatch, total)
    small = [d for d in range(1, math.isqrt(total) + 1) if total % d == 0]
    size = min({*small, *(total // d for d in small)}, key=lambda d: (abs(d - minibatch), -d))
    if 2 * size < minibatch or size > 2 * minibatch:
        return horizon(total, envs, minibatch), minibatch
    return steps, size


def sequence_batch_shape(batch: int, envs: int, minibatch: int, seq_len: int) -> tuple[int, int]:
    """(steps per env per epoch, minibatch size) for an RNN trained on sequences of ``seq_len`` steps: the horizon
    is the smallest multiple of ``seq_len`` that holds ``batch`` over the envs, the minibatch the whole number of
    sequences dividing the epoch that is nearest ``minibatch`` in size."""
    steps = max(1, math.ceil(batch / envs / seq_len)) * seq_len
    sequences = envs * steps // seq_len
    fits = [n * seq_len for n in range(1, sequences + 1) if sequences % n == 0]
    return steps, min(fits, key=lambda m: (abs(m - minibatch), m))


def horizon(batch: int, envs: int, minibatch: int) -> int:
    """Steps per env per epoch: the smallest that gives at least ``batch`` frames in whole minibatches."""
    step = minibatch // math.gcd(minibatch, envs)  # horizon multiple of this: envs * horizon % minibatch == 0
    per_env = math.ceil(batch / envs)
    return max(step, math.ceil(per_env / step) * step)


def _positive(config: Any, key: str, kind: type = int) -> Any:
    value = config._settings.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value <= 0 \
            or (kind is int and int(value) != value):
        raise _bad(config, key, f"expected a {'whole ' if kind is int else ''}number > 0, got {value!r}")
    return kind(value)


def ppo_config(config: Any, env_name: str, continuous: bool, run: dict[str, Any],
               obs_space: Any = None, rllib_batch: bool = True) -> dict[str, Any]:
    """The rlchain PPO config of an RLlib ``PPOConfig`` on ``env_name`` (see the module docstring). ``run``:
    further ``params.config`` keys (name, train_dir, device, ...); ``obs_space``: the env's (images and
    ``use_lstm`` map onto rlchain's cnn / rnn blocks, :mod:`rlchain.rllib.networks`). ``rllib_batch``: RLlib's
    train batch (its masked bootstrap rows in the advantage standardization; a feed-forward policy's minibatches
    in RLlib's cyclic order, of ``minibatch_size`` rows: rlchain.algos.ppo.rllib_batch); False (the multi-agent
    face, whose policies pick their own active steps): whole minibatches shuffled, advantages standardized over
    the steps."""
    check_supported(config)
    s = config._settings
    envs = num_envs(config)
    ranks = learners(config)
    batch = -(-config.total_train_batch_size // ranks)  # each learner process samples its share of the batch
    minibatch = _positive(config, "minibatch_size")
    if minibatch > batch:
        minibatch = batch
    network, seq_len = actor_critic_network(config, obs_space, continuous)
    # RLlib's cyclic minibatches; not across learners (each would take its own count of minibatch steps, and every
    # step all-reduces the gradients): there whole minibatches, the same count on every rank
    cyclic = rllib_batch and ranks == 1 and not seq_len and s.get("shuffle_batch_per_epoch", True)
    if seq_len:
        steps, minibatch = sequence_batch_shape(batch, envs, minibatch, seq_len)
    elif cyclic:  # RLlib's cyclic minibatches: the batch need not divide
        steps = fragment_length(batch, envs, s.get("rollout_fragment_length", "auto"))
    else:
        steps, minibatch = batch_shape(batch, envs, minibatch, s.get("rollout_fragment_length", "auto"))
    grad_clip = s.get("grad_clip")
    kl_on = bool(s.get("use_kl_loss")) and float(s.get("kl_coeff") or 0.0) > 0
    lr = s.get("lr")
    if isinstance(lr, (list, tuple)):
        raise _bad(config, "lr", "a schedule list is not mapped: a constant lr")
    entropy = s.get("entropy_coeff")
    if isinstance(entropy, (list, tuple)):
        raise _bad(config, "entropy_coeff", "a schedule list is not mapped: a constant entropy_coeff")
    train = {
        "env_name": env_name, "num_actors": envs, "horizon_length": steps, "minibatch_size": minibatch,
        "mini_epochs": _positive(config, "num_epochs"), "learning_rate": float(lr), "lr_schedule": None,
        "gamma": float(s["gamma"]), "tau": float(s["lambda_"]) if s.get("use_gae", True) else 1.0,
        "e_clip": float(s["clip_param"]), "clip_value": False,
        "value_loss_clip": None if s.get("vf_clip_param") is None else float(s["vf_clip_param"]),
        "critic_coef": 2.0 * float(s["vf_loss_coeff"]), "entropy_coef": float(entropy or 0.0),
        "kl_loss_coef": float(s["kl_coeff"]) if kl_on else 0.0,
        "kl_loss_target": float(s["kl_target"]) if kl_on else None, "kl_reference": "rollout",
        "grad_norm": float(grad_clip) if grad_clip is not None else 1.0, "truncate_grads": grad_clip is not None,
        "normalize_advantage": True, "advantage_normalization": "rllib" if rllib_batch else "batch",
        "normalize_input": False,
        "normalize_value": False, "value_bootstrap": True, "reward_shaper": {"scale_value": 1.0},
        "minibatch_order": "rllib" if cyclic else "shuffle" if s.get("shuffle_batch_per_epoch", True) else "fixed",
        "games_to_track": int(s.get("metrics_num_episodes_for_smoothing") or 100),
        "bounds_loss_coef": None, "clip_actions": bool(continuous), "env_config": {},
        "save_best_after": 10**9, "score_to_win": float("inf"), "max_epochs": -1, "multi_gpu": ranks > 1,
        # RLlib compiles its learner's forward pass; rlchain's compile_update compiles the minibatch step's forward
        # pass and losses (the backward derived from them): single-policy feed-forward PPO only, others train eager
        "compile_update": bool(s.get("torch_compile_learner")) and not seq_len and rllib_batch,
    }
    if seq_len:
        train["seq_length"] = seq_len
    train.update(filter_keys(config))  # RLlib's MeanStdFilter connector: the observation normalizer
    train.update(env_runner_keys(config, "PPO"))
    train.update(run)
    algo, model = ("a2c_continuous", "continuous_a2c_logstd") if continuous else ("a2c_discrete", "discrete_a2c")
    params = {"algo": {"name": algo}, "model": {"name": model}, "network": network, "config": train}
    if s.get("seed") is not None:
        params["seed"] = int(s["seed"])
    return {"params": params}


def update_rounds(config: Any) -> dict[str, int]:
    """RLlib's replay ratio as rlchain's ``num_updates_per_step`` updates every ``update_every`` vectorized steps.

    RLlib's off-policy ``training_step`` samples one round (``rollout_fragment_length`` steps, "auto": ``n_step``,
    of every env) and makes one update of ``train_batch_size``; ``training_intensity`` (replayed / sampled steps)
    changes the ratio of rounds to updates (RLlib's ``calculate_rr_weights``): ``rounds`` sampling rounds, then
    ``updates`` updates, which is ``updates`` updates after every ``rounds * fragment`` vectorized steps.
    """
    s = config._settings
    fragment = s.get("rollout_fragment_length")
    if fragment in (None, "auto"):
        n_step = s.get("n_step") or 1
        fragment = n_step[1] if isinstance(n_step, (list, tuple)) else n_step
    fragment = max(1, int(fragment))
    intensity = s.get("training_intensity")
    rounds, updates = 1, 1
    if intensity:
        per_runner = max(1, int(s.get("num_envs_per_env_runner") or 1))
        native = config.total_train_batch_size / (fragment * per_runner
                                                  * max(int(s.get("num_env_runners") or 0) + 1, 1))
        weight = float(intensity) / native
        rounds, updates = (max(1, round(1 / weight)), 1) if weight < 1 else (1, max(1, round(weight)))
    return {"num_updates_per_step": updates, "update_every": rounds * fragment}


def n_steps(config: Any) -> dict[str, int | None]:
    """RLlib's ``n_step`` as rlchain's ``n_step`` / ``n_step_max``: a whole number, or a range ``(lo, hi)`` from
    which RLlib's replay buffer draws each sampled transition's n with numpy's ``integers(lo, hi)`` (lo to hi - 1;
    rlchain draws it once per stored transition)."""
    value = config._settings.get("n_step")
    if isinstance(value, int) and not isinstance(value, bool) and value >= 1:
        return {"n_step": value, "n_step_max": None}
    if isinstance(value, (list, tuple)) and len(value) == 2 \
            and all(isinstance(v, int) and not isinstance(v, bool) for v in value) and 1 <= value[0] < value[1]:
        return {"n_step": int(value[0]), "n_step_max": int(value[1]) - 1 if value[1] - 1 > value[0] else None}
    raise _bad(config, "n_step", f"expected a whole number >= 1 or a range (lo, hi) with 1 <= lo < hi, got {value!r}")


def _epsilon(config: Any) -> tuple[float, float, int]:
    """RLlib's epsilon schedule [(t0, start), ..., (t1, end)] (or a number) as (start, end, decay frames)."""
    value = config._settings.get("epsilon")
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value), float(value), 1
    points = [tuple(p) for p in (value or [])]
    if len(points) < 2 or any(len(p) != 2 for p in points):
        raise _bad(config, "epsilon", f"expected [(0, start), (steps, end)] or a number, got {value!r}")
    (t0, start), (t1, end) = points[0], points[-1]
    return float(start), float(end), max(1, int(t1) - int(t0))


def dqn_config(config: Any, env_name: str, run: dict[str, Any]) -> dict[str, Any]:
    """The rlchain DQN config of an RLlib ``DQNConfig``: one ``train()`` = ``min_sample_timesteps_per_iteration``
    env steps (1000), RLlib's replay ratio (one update of ``train_batch_size`` per sampling round, or
    ``training_intensity``: :func:`update_rounds`), ``target_network_update_freq`` in env steps, the epsilon
    schedule, double / dueling Q, ``n_step`` (or a range), prioritized replay (RLlib's default buffer); the
    Q-network as RLlib 2.60's DQN module: ``fcnet_hiddens`` then, per stream, ``head_fcnet_hiddens`` (the old
    stack's ``hiddens`` is kept with no effect, as in RLlib's new stack)."""
    check_supported(config)
    s = config._settings
    for key, off in (("noisy", False), ("num_atoms", 1)):
        if s.get(key) not in (off, None):
            raise _bad(config, key, f"{s.get(key)!r} is not offered: rlchain's DQN is not noisy / distributional")
    envs = num_envs(config)
    batch = config.total_train_batch_size  # train_batch_size_per_learner where set (RLlib's new stack), as RLlib
    rounds = update_rounds(config)
    replay = s.get("replay_buffer_config") or {}
    start, end, decay = _epsilon(config)
    steps = max(1, -(-int(s.get("min_sample_timesteps_per_iteration") or 1000) // envs))
    units = layer_sizes(config, "fcnet_hiddens")  # RLlib 2.60's DQN module: hiddens is the old stack's key
    heads = layer_sizes(config, "head_fcnet_hiddens")
    grad_clip = s.get("grad_clip")
    train = {
        "env_name": env_name, "num_actors": envs, "gamma": float(s["gamma"]), "learning_rate": float(s["lr"]),
        "double_dqn": bool(s.get("double_q", True)), **n_steps(config), "batch_size": batch,
        "replay_buffer_size": int(replay.get("capacity", 50000)),
        "prioritized_replay": "Prioritized" in str(replay.get("type", "")),
        "priority_alpha": float(replay.get("alpha", 0.6)), "priority_beta": float(replay.get("beta", 0.4)),
        "num_warmup_frames": int(s.get("num_steps_sampled_before_learning_starts") or 0),
        "save_replay_buffer": bool(s.get("store_buffer_in_checkpoints")),
        "num_steps_per_episode": steps, **rounds,
        "target_update_frequency": max(1, round(int(s["target_network_update_freq"]) * rounds["num_updates_per_step"]
                                                 / (rounds["update_every"] * envs))),
        "target_tau": float(s.get("tau", 1.0)), "epsilon_start": start, "epsilon_end": end,
        "epsilon_decay_frames": decay, "loss": "mse" if s.get("td_error_loss_fn") == "mse" else "huber",
        "grad_norm": None if grad_clip is None else float(grad_clip),
        "games_to_track": int(s.get("metrics_num_episodes_for_smoothing") or 100),
        "save_best_after": 10**9, "score_to_win": float("inf"), "max_epochs": -1,
    }
    train.update(env_runner_keys(config, "DQN"))
    train.update(run)
    network = {"name": "dqn", "dueling": bool(s.get("dueling", True)), "space": {"discrete": None},
               "mlp": {"units": units, "activation": activation(config, "fcnet_activation"),
                       "initializer": {"name": "default"}}}
    if heads:  # each stream's own layers, as RLlib's DQN catalog builds its advantage and value heads
        network["head"] = {"units": heads, "activation": activation(config, "head_fcnet_activation"),
                           "initializer": {"name": "default"}}
    params = {"algo": {"name": "dqn"}, "model": {"name": "dqn"}, "network": network, "config": train}
    if s.get("seed") is not None:
        params["seed"] = int(s["seed"])
    return {"params": params}
