"""An RLlib ``SACConfig`` -> the rlchain SAC config that trains it.

What maps (RLlib 2.60's defaults in brackets):

- ``actor_lr`` (3e-5), ``critic_lr`` (3e-4), ``alpha_lr`` (3e-4), ``initial_alpha`` (1.0) -> the same rlchain keys
  (``init_alpha``); ``target_entropy`` ("auto": -prod(action shape), which is -1 for a Discrete space: RLlib's
  learner takes the shape, not the number of actions) -> ``target_entropy``; ``tau`` (5e-3) ->
  ``critic_tau``, the target critics follow after every update (``target_network_update_freq`` 0, or at most
  the env steps sampled before each update: RLlib's rule then moves them after every update too);
- ``train_batch_size_per_learner`` (256: RLlib 2.60's SACConfig sets it, so ``train_batch_size`` alone changes
  nothing, as in RLlib) -> ``batch_size``; ``replay_buffer_config`` (prioritized, 1e6, alpha 0.6, beta 0.4)
  -> ``replay_buffer_size``, ``prioritized_replay``, ``priority_alpha`` / ``priority_beta``; ``n_step`` (1; a
  range ``(lo, hi)``: :func:`~rlchain.rllib.translate.n_steps`); ``num_steps_sampled_before_learning_starts``
  (1500) -> ``num_warmup_frames``; RLlib's replay ratio (one update per sampled round, or
  ``training_intensity``) -> ``num_updates_per_step`` every ``update_every`` steps; ``grad_clip`` ->
  ``grad_norm``; ``store_buffer_in_checkpoints`` -> ``save_replay_buffer``;
- one ``train()`` = ``min_sample_timesteps_per_iteration`` (100) env steps;
- the model: ``fcnet_hiddens`` then ``head_fcnet_hiddens`` with ``fcnet_activation`` for the actor and both
  critics; Box actions: ``log_std_clip_param`` (20) clips the log-std to [-20, 20]; actions squashed to [-1, 1]
  and rescaled to the env's bounds (``normalize_actions``, RLlib's default); Discrete actions: the actor gives
  the categorical's logits and each critic reads the observation alone and gives one Q-value per action, as
  RLlib's discrete SAC module (its loss: expectations over the categorical's probabilities, rlchain's
  ``sac_discrete``).

Each critic's TD loss is RLlib's Huber loss (delta 1): ``loss: huber``. What does not map: ``twin_q=False``
(rlchain's SAC always has twin critics), a ``target_network_update_freq`` above the env steps sampled before
each update, the old-stack ``_deterministic_loss`` / ``_use_beta_distribution``: each a
one-line error. Warmup actions are uniform (RLlib samples its initial policy).
"""

from __future__ import annotations

from typing import Any

from rlchain.rllib import translate as T
from rlchain.rllib.env_runners import env_runner_keys
from rlchain.rllib.networks import activation, layer_sizes


def _number(config: Any, key: str) -> float:
    value = config._settings.get(key)
    if isinstance(value, (list, tuple)):
        raise T._bad(config, key, "a schedule list is not mapped: a constant")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value <= 0:
        raise T._bad(config, key, f"expected a number > 0, got {value!r}")
    return float(value)


def _check_target_updates(config: Any) -> None:
    """RLlib's SAC learner moves the targets after a gradient step when ``target_network_update_freq`` env steps
    were sampled since its last move; rlchain's SAC moves them after every update. The two agree while every update
    follows at least that many new env steps (one update per sampling round of ``update_every`` steps of every
    env): RLlib's tuned examples set 1. A larger value, or several updates per round, is refused in one line."""
    freq = config._settings.get("target_network_update_freq") or 0
    if isinstance(freq, bool) or not isinstance(freq, int) or freq < 0:
        raise T._bad(config, "target_network_update_freq", f"expected a whole number >= 0, got {freq!r}")
    rounds = T.update_rounds(config)
    sampled = rounds["update_every"] * T.num_envs(config)  # env steps sampled before each update
    if freq and (rounds["num_updates_per_step"] > 1 or freq > sampled):
        raise T._bad(config, "target_network_update_freq",
                     f"{freq!r}: rlchain's SAC moves its target critics by tau after every update, which is RLlib's "
                     f"rule only while each update follows {freq} or more new env steps (here {sampled} env steps, "
                     f"{rounds['num_updates_per_step']} update(s) per round): use 0")


def auto_target_entropy(continuous: bool) -> float | None:
    """RLlib's ``target_entropy="auto"``: -prod(action_space.shape), which rlchain's default (-action dims) gives
    for Box actions (None); for Discrete actions (shape ()) it is -1.0, not rlchain's discrete default."""
    return None if continuous else -1.0


def sac_config(config: Any, env_name: str, run: dict[str, Any], continuous: bool = True) -> dict[str, Any]:
    """The rlchain SAC config of an RLlib ``SACConfig`` on ``env_name`` with Box (``continuous``) or Discrete
    actions (see the module docstring)."""
    T.check_supported(config)
    s = config._settings
    refused = {"twin_q": (False, "rlchain's SAC always trains twin critics"),
               "_deterministic_loss": (True, "rlchain's SAC samples the policy in its losses"),
               "_use_beta_distribution": (True, "rlchain's SAC policy is a tanh-squashed Gaussian")}
    for key, (value, why) in refused.items():
        if s.get(key) == value:
            raise T._bad(config, key, f"{value!r} is not offered: {why}")
    _check_target_updates(config)
    target_entropy = s.get("target_entropy")
    if target_entropy not in ("auto", None) and (isinstance(target_entropy, bool)
                                                 or not isinstance(target_entropy, (int, float))):
        raise T._bad(config, "target_entropy", f"expected 'auto' or a number, got {target_entropy!r}")
    envs = T.num_envs(config)
    replay = s.get("replay_buffer_config") or {}
    clip = config.model_config.get("log_std_clip_param")
    grad_clip = s.get("grad_clip")
    batch = config.total_train_batch_size
    train = {
        "env_name": env_name, "num_actors": envs, "gamma": float(s["gamma"]),
        "actor_lr": _number(config, "actor_lr"), "critic_lr": _number(config, "critic_lr"),
        "alpha_lr": _number(config, "alpha_lr"), "init_alpha": _number(config, "initial_alpha"), "loss": "huber",
        "learnable_temperature": True,
        "target_entropy": auto_target_entropy(continuous) if target_entropy in ("auto", None)
        else float(target_entropy),
        "critic_tau": float(s["tau"]), "policy_frequency": 1, "batch_size": batch,
        "replay_buffer_size": max(batch, int(replay.get("capacity", 1_000_000))),
        "prioritized_replay": "Prioritized" in str(replay.get("type", "")),
        "priority_alpha": float(replay.get("alpha", 0.6)), "priority_beta": float(replay.get("beta", 0.4)),
        **T.n_steps(config), "save_replay_buffer": bool(s.get("store_buffer_in_checkpoints")),
        "num_warmup_frames": int(s.get("num_steps_sampled_before_learning_starts") or 0),
        "num_steps_per_episode": max(1, -(-int(s.get("min_sample_timesteps_per_iteration") or 100) // envs)),
        **T.update_rounds(config),
        "grad_norm": None if grad_clip is None else float(grad_clip),
        "clip_actions": bool(s.get("normalize_actions", True)), "normalize_input": False,
        "reward_shaper": {"scale_value": 1.0},
        "log_std_bounds": None if clip is None or not continuous else [-float(clip), float(clip)],
        "games_to_track": int(s.get("metrics_num_episodes_for_smoothing") or 100),
        "save_best_after": 10**9, "score_to_win": float("inf"), "max_epochs": -1,
    }
    train.update(env_runner_keys(config, "SAC"))
    train.update(run)
    units = layer_sizes(config, "fcnet_hiddens")
    act = activation(config, "fcnet_activation")
    heads = layer_sizes(config, "head_fcnet_hiddens")
    if heads:
        if units and activation(config, "head_fcnet_activation") != act:
            raise T._bad(config, "model_config.head_fcnet_activation", "differs from fcnet_activation: rlchain's SAC "
                                                                       "networks have one activation")
        act = activation(config, "head_fcnet_activation")
        units = units + heads
    space = "continuous" if continuous else "discrete"
    network = {"name": "soft_actor_critic", "separate": True, "space": {space: None},
               "mlp": {"units": units, "activation": act, "initializer": {"name": "default"}}}
    if clip is not None and continuous:
        network["log_std_bounds"] = [-float(clip), float(clip)]
    params = {"algo": {"name": "sac"}, "model": {"name": "soft_actor_critic"}, "network": network, "config": train}
    if s.get("seed") is not None:
        params["seed"] = int(s["seed"])
    return {"params": params}
