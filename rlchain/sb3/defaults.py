"""Stable-Baselines3's own hyperparameters and semantics as rlchain config values (plain data).

``rlchain.PPO("MlpPolicy", env)`` starts from these (``defaults="sb3"``, the default), so a script written for
SB3 trains the algorithm SB3 trains: PPO with 2,048-step rollouts of one env, 10 epochs of 64-sample minibatches,
``learning_rate`` 3e-4 constant, ``vf_coef`` 0.5 (rlchain's ``critic_coef`` 1.0: its value loss is halved),
``max_grad_norm`` 0.5, no value clipping (``clip_range_vf=None``), no reward scaling, no input or value
normalization, separate 64-64 tanh actor and critic with orthogonal initialization. ``defaults="rlchain"`` starts
from rlchain's packaged examples instead (:func:`rlchain.sb3.keys.packaged_defaults`).

Advantages are normalized per minibatch, as SB3 does (``advantage_normalization: minibatch``). What differs from
SB3 and stays: the action heads keep torch's default initialization (SB3: orthogonal, gains 0.01 and 1); PPO's
continuous actions go to the env as the policy samples them (``clip_actions: False``; SB3 clips them to the
bounds first: ``predict`` and an SB3 vec env do here too, a gymnasium env clips them itself or not). DQN makes one
update after every 4th step of its envs, as SB3's ``train_freq=4`` (rlchain's ``update_every``).
"""

from __future__ import annotations

from typing import Any

_ORTHOGONAL = {"name": "orthogonal_initializer", "gain": 2 ** 0.5}

SB3_DEFAULTS: dict[str, dict[str, Any]] = {
    "ppo": {"network": {"name": "actor_critic", "separate": True,
                        "mlp": {"units": [64, 64], "activation": "tanh", "initializer": _ORTHOGONAL}},
            "config": {"normalize_advantage": True, "advantage_normalization": "minibatch", "normalize_input": False,
                       "normalize_value": False,
                       "value_bootstrap": True, "gamma": 0.99, "tau": 0.95, "learning_rate": 3e-4,
                       "lr_schedule": None, "grad_norm": 0.5, "truncate_grads": True, "entropy_coef": 0.0,
                       "e_clip": 0.2, "clip_value": False, "horizon_length": 2048, "minibatch_size": 64,
                       "mini_epochs": 10, "critic_coef": 1.0, "save_best_after": 5}},
    "ppo_continuous": {"network": {"space": {"continuous": {"mu_activation": "None", "sigma_activation": "None",
                                                            "mu_init": {"name": "default"},
                                                            "sigma_init": {"name": "const_initializer", "val": 0},
                                                            "fixed_sigma": True}}},
                       "config": {"bounds_loss_coef": 0.0, "clip_actions": False}},
    "sac": {"network": {"name": "soft_actor_critic", "separate": True, "space": {"continuous": None},
                        "mlp": {"units": [256, 256], "activation": "relu", "initializer": {"name": "default"}},
                        "log_std_bounds": [-20, 2]},
            "config": {"normalize_input": False, "gamma": 0.99, "init_alpha": 1.0, "alpha_lr": 3e-4,
                       "actor_lr": 3e-4, "critic_lr": 3e-4, "critic_tau": 0.005, "learnable_temperature": True,
                       "batch_size": 256, "num_steps_per_episode": 100, "num_updates_per_step": 1,
                       "policy_frequency": 1, "num_warmup_frames": 100, "replay_buffer_size": 1_000_000,
                       "save_best_after": 10}},
    "dqn": {"network": {"name": "dqn", "dueling": False, "space": {"discrete": None},
                        "mlp": {"units": [64, 64], "activation": "relu", "initializer": {"name": "default"}}},
            "config": {"gamma": 0.99, "learning_rate": 1e-4, "double_dqn": False, "n_step": 1, "batch_size": 32,
                       "num_steps_per_episode": 100, "num_updates_per_step": 1, "update_every": 4,
                       "num_warmup_frames": 100,
                       "replay_buffer_size": 1_000_000, "target_update_frequency": 10_000, "target_tau": 1.0,
                       "epsilon_start": 1.0, "epsilon_end": 0.05, "epsilon_decay_frames": 10_000, "loss": "huber",
                       "grad_norm": 10, "save_best_after": 10}},
}

SB3_NUM_ENVS = {"ppo": 1, "sac": 1, "dqn": 1}
"""SB3 steps one env when given an id or an env object (``make_vec_env``'s default)."""

SB3_TRAIN_FREQ = {"dqn": 4, "sac": 1}
"""SB3's default ``train_freq`` per algorithm (env steps between update rounds)."""

SB3_EXPLORATION_FRACTION = 0.1  # DQN: epsilon decays over this fraction of total_timesteps

CHOICES = ("sb3", "rlchain")
