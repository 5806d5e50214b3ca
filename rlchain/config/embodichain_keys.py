"""EmbodiChain's ``train_config.json`` keys and defaults, and the one check that rejects a key it does not
have (EmbodiChain ignores such a key silently; here it is a one-line error with a did-you-mean)."""

from __future__ import annotations

from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.errors import did_you_mean

TOP_KEYS = ("trainer", "policy", "algorithm")
TRAINER_KEYS = {
    "exp_name", "gym_config", "learning_env", "seed", "device", "headless", "gpu_id", "num_envs", "iterations",
    "buffer_size", "rollout_steps", "enable_eval", "num_eval_envs", "num_eval_episodes", "eval_freq",
    "save_freq", "eval_seed", "best_eval_metric", "best_eval_mode", "use_wandb", "wandb_project_name", "events",
    "renderer", "distributed", "total_timesteps", "segment_length", "update_horizon", "deterministic_actions",
    "save_frequency_updates", "enable_rt",
}
SIM_ONLY_KEYS = ("headless", "gpu_id", "renderer", "enable_rt")  # DexSim's window, GPU, renderer, ray tracing
POLICY_KEYS = {"name", "actor", "critic", "initial_log_std", "action_dim"}
MODULE_KEYS = {"type", "network_cfg"}
NETWORK_KEYS = {"hidden_sizes", "activation", "last_activation", "use_layernorm", "dropout_p", "orthogonal_init"}
ALGORITHM_KEYS = {"name", "cfg"}
COMMON_CFG = {"optimizer", "lr_scheduler", "batch_size", "gamma", "gae_lambda", "max_grad_norm", "device",
              "learning_rate"}
ALGO_CFG = {
    "ppo": COMMON_CFG | {"n_epochs", "clip_coef", "ent_coef", "vf_coef"},
    "grpo": COMMON_CFG | {"n_epochs", "clip_coef", "ent_coef", "kl_coef", "group_size", "eps",
                          "reset_every_rollout", "truncate_at_first_done", "shared_starts"},
    "apg": COMMON_CFG | {"ent_coef", "skip_nonfinite_updates"},
}
RLCHAIN_ALGO = {"ppo": "a2c_continuous", "grpo": "grpo", "apg": "apg"}
POLICY_FOR = {"ppo": "actor_critic", "grpo": "actor_only", "apg": "actor_only"}
ACTIVATIONS = {"relu": "relu", "elu": "elu", "tanh": "tanh", "sigmoid": "sigmoid", "selu": "selu",
               "gelu": "gelu", "silu": "swish", "swish": "swish", "softplus": "softplus", "none": "None",
               "identity": "None"}
CAMERA_EVENTS = ("record_camera_data", "record_camera_data_async")
# EmbodiChain's defaults where a key is absent (train.py, utils/config.py, algo/*.py); a learning_env run
# (its _train_learning_env) has its own for a few trainer keys
DEFAULTS = {"seed": 1, "iterations": 250, "buffer_size": 2048, "eval_freq": 10000, "save_freq": 50000,
            "num_eval_episodes": 5, "num_eval_envs": 4, "num_envs": 64, "learning_rate": 3e-4, "batch_size": 64,
            "gamma": 0.99, "gae_lambda": 0.95, "max_grad_norm": 0.5, "n_epochs": 10, "clip_coef": 0.2,
            "vf_coef": 0.5}
LEARNING_ENV_DEFAULTS = {"buffer_size": 256, "eval_freq": 0, "save_freq": 0, "num_eval_envs": 16}
ENT_DEFAULT = {"ppo": 0.01, "grpo": 0.0, "apg": 0.0}
LOG_STD_BOUNDS = [-5.0, 2.0]


def reject_unknown(keys: Any, known: set[str], path: str, source: str) -> None:
    """A one-line error for the first of ``keys`` not in ``known`` (with a did-you-mean), naming ``path``."""
    for key in keys:
        if key not in known:
            hint = did_you_mean(key, known) or f"; known keys: {', '.join(sorted(known))}"
            raise ConfigError(source, f"{path}.{key}", f"unknown key (EmbodiChain ignores it silently){hint}")
