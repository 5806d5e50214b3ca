"""RLlib's config keys: which builder method takes which, RLlib's defaults, its old-stack names, and what
the face does with each.

Every key RLlib 2.x's ``AlgorithmConfig`` builders take is accepted (a script that sets resources or
logging options runs). A key the translation reads (:mod:`rlchain.rllib.translate`) has RLlib's meaning; a key
in :data:`UNSUPPORTED` set to anything but its default is a one-line error saying what to use instead; the
rest (resources, Ray placement, TensorFlow and logging details) are kept in the config and have no effect on
rlchain's single-process loop. A name RLlib does not know is a one-line error with a did-you-mean.
"""

from __future__ import annotations

from typing import Any

METHOD_KEYS: dict[str, tuple[str, ...]] = {
    "environment": ("env", "env_config", "observation_space", "action_space", "render_env", "clip_rewards",
                    "normalize_actions", "clip_actions", "disable_env_checking", "is_atari", "action_mask_key",
                    "env_task_fn"),
    "training": ("gamma", "lr", "grad_clip", "grad_clip_by", "train_batch_size", "train_batch_size_per_learner",
                 "num_epochs", "minibatch_size", "shuffle_batch_per_epoch", "model", "optimizer",
                 "num_aggregator_actors_per_learner", "max_requests_in_flight_per_aggregator_actor", "num_sgd_iter",
                 "sgd_minibatch_size", "learner_class", "learner_connector",
                 "add_default_connectors_to_learner_pipeline", "learner_config_dict", "lr_schedule"),
    "env_runners": ("env_runner_cls", "num_env_runners", "create_local_env_runner", "create_env_on_local_worker",
                    "num_envs_per_env_runner", "gym_env_vectorize_mode", "num_cpus_per_env_runner",
                    "num_gpus_per_env_runner", "custom_resources_per_env_runner",
                    "validate_env_runners_after_construction", "sample_timeout_s",
                    "max_requests_in_flight_per_env_runner", "env_to_module_connector", "module_to_env_connector",
                    "add_default_connectors_to_env_to_module_pipeline",
                    "add_default_connectors_to_module_to_env_pipeline", "episode_lookback_horizon",
                    "merge_env_runner_states", "broadcast_env_runner_states", "use_env_runner_state_server",
                    "compress_observations", "rollout_fragment_length", "batch_mode", "explore",
                    "episodes_to_numpy", "use_worker_filter_stats", "update_worker_filter_stats",
                    "exploration_config", "sample_collector", "remote_worker_envs", "remote_env_batch_wait_ms",
                    "preprocessor_pref", "observation_filter", "enable_tf1_exec_eagerly",
                    "sampler_perf_stats_ema_coef", "num_rollout_workers", "num_envs_per_worker",
                    "validate_workers_after_construction", "ignore_worker_failures", "recreate_failed_workers",
                    "restart_failed_sub_environments", "num_consecutive_worker_failures_tolerance",
                    "worker_health_probe_timeout_s", "worker_restore_timeout_s", "synchronize_filter",
                    "enable_connectors"),
    "learners": ("num_learners", "num_cpus_per_learner", "num_gpus_per_learner", "custom_resources_per_learner",
                 "num_aggregator_actors_per_learner", "max_requests_in_flight_per_aggregator_actor",
                 "local_gpu_idx", "max_requests_in_flight_per_learner", "learner_class", "learner_connector",
                 "add_default_connectors_to_learner_pipeline", "learner_config_dict"),
    "resources": ("num_cpus_for_main_process", "custom_resources_for_main_process", "num_gpus", "_fake_gpus",
                  "placement_strategy", "num_cpus_per_worker", "num_gpus_per_worker", "custom_resources_per_worker",
                  "num_learner_workers", "num_cpus_per_learner_worker", "num_gpus_per_learner_worker",
                  "local_gpu_idx", "num_cpus_for_local_worker"),
    "evaluation": ("evaluation_interval", "evaluation_duration", "evaluation_duration_unit",
                   "evaluation_sample_timeout_s", "evaluation_parallel_to_training",
                   "evaluation_force_reset_envs_before_iteration", "evaluation_config",
                   "evaluation_num_env_runners", "custom_evaluation_function", "always_attach_evaluation_results",
                   "evaluation_num_workers", "evaluation_auto_duration_min_env_steps_per_sample",
                   "evaluation_auto_duration_max_env_steps_per_sample", "evaluation_unhealthy_workers_timeout_s",
                   "evaluation_error_after_n_consecutive_skips", "off_policy_estimation_methods",
                   "ope_split_batch_by_episode"),
    "reporting": ("keep_per_episode_custom_metrics", "metrics_episode_collection_timeout_s",
                  "metrics_num_episodes_for_smoothing", "min_time_s_per_iteration", "min_train_timesteps_per_iteration",
                  "min_sample_timesteps_per_iteration", "log_gradients", "custom_stats_cls_lookup"),
    "framework": ("framework", "eager_tracing", "eager_max_retraces", "tf_session_args", "local_tf_session_args",
                  "torch_compile_learner", "torch_compile_learner_what_to_compile",
                  "torch_compile_learner_dynamo_mode", "torch_compile_learner_dynamo_backend",
                  "torch_compile_worker", "torch_compile_worker_dynamo_backend", "torch_compile_worker_dynamo_mode",
                  "torch_ddp_kwargs", "torch_skip_nan_gradients"),
    "debugging": ("log_level", "log_sys_usage", "fake_sampler", "seed"),
    "multi_agent": ("policies", "policy_map_capacity", "policy_mapping_fn", "policies_to_train",
                    "policy_states_are_swappable", "observation_fn", "count_steps_by",
                    "algorithm_config_overrides_per_module", "replay_mode", "policy_map_cache"),
    "rl_module": ("model_config", "rl_module_spec", "algorithm_config_overrides_per_module", "model_config_dict",
                  "_enable_rl_module_api"),
    "callbacks": ("callbacks_class", "on_algorithm_init", "on_train_result", "on_evaluate_start", "on_evaluate_end",
                  "on_env_runners_recreated", "on_checkpoint_loaded", "on_environment_created",
                  "on_episode_created", "on_episode_start", "on_episode_step", "on_episode_end", "on_sample_end"),
    "fault_tolerance": ("restart_failed_env_runners", "ignore_env_runner_failures", "max_num_env_runner_restarts",
                        "delay_between_env_runner_restarts_s", "restart_failed_sub_environments",
                        "num_consecutive_env_runner_failures_tolerance", "env_runner_health_probe_timeout_s",
                        "env_runner_restore_timeout_s", "recreate_failed_env_runners", "ignore_worker_failures",
                        "recreate_failed_workers", "max_num_worker_restarts", "delay_between_worker_restarts_s",
                        "num_consecutive_worker_failures_tolerance", "worker_health_probe_timeout_s",
                        "worker_restore_timeout_s"),
    "api_stack": ("enable_rl_module_and_learner", "enable_env_runner_and_connector_v2"),
    "checkpointing": ("export_native_model_files", "checkpoint_trainable_policies_only"),
    "offline_data": ("input_", "output"),
    "experimental": ("_validate_config", "_use_msgpack_checkpoints", "_torch_grad_scaler_class",
                     "_torch_lr_scheduler_classes", "_tf_policy_handles_more_than_one_loss",
                     "_disable_preprocessor_api", "_disable_action_flattening",
                     "_disable_initialize_loss_from_dummy_batch"),
}
"""Each builder method's keyword names, as RLlib 2.60's builders take them (each algorithm's ``training``
adds its own: :data:`ALGO_TRAINING_KEYS`)."""

ALGO_TRAINING_KEYS: dict[str, tuple[str, ...]] = {
    "PPO": ("use_critic", "use_gae", "lambda_", "use_kl_loss", "kl_coeff", "kl_target", "vf_loss_coeff",
            "entropy_coeff", "entropy_coeff_schedule", "clip_param", "vf_clip_param", "vf_share_layers"),
    "DQN": ("target_network_update_freq", "replay_buffer_config", "store_buffer_in_checkpoints", "epsilon",
            "adam_epsilon", "num_steps_sampled_before_learning_starts", "tau", "num_atoms", "v_min", "v_max",
            "noisy", "sigma0", "dueling", "hiddens", "double_q", "n_step", "before_learn_on_batch",
            "training_intensity", "td_error_loss_fn", "categorical_distribution_temperature", "burn_in_len"),
    "IMPALA": ("vtrace", "vtrace_clip_rho_threshold", "vtrace_clip_pg_rho_threshold", "num_gpu_loader_threads",
               "num_multi_gpu_tower_stacks", "minibatch_buffer_size", "replay_proportion", "replay_buffer_num_slots",
               "learner_queue_size", "learner_queue_timeout", "timeout_s_sampler_manager",
               "timeout_s_aggregator_manager", "broadcast_interval", "opt_type", "decay", "momentum", "epsilon",
               "vf_loss_coeff", "entropy_coeff", "entropy_coeff_schedule", "_separate_vf_optimizer", "_lr_vf"),
    "APPO": ("vtrace", "vtrace_clip_rho_threshold", "vtrace_clip_pg_rho_threshold", "num_gpu_loader_threads",
             "num_multi_gpu_tower_stacks", "minibatch_buffer_size", "replay_proportion", "replay_buffer_num_slots",
             "learner_queue_size", "learner_queue_timeout", "timeout_s_sampler_manager",
             "timeout_s_aggregator_manager", "broadcast_interval", "opt_type", "decay", "momentum", "epsilon",
             "vf_loss_coeff", "entropy_coeff", "entropy_coeff_schedule", "_separate_vf_optimizer", "_lr_vf",
             "use_gae", "lambda_", "clip_param", "use_kl_loss", "kl_coeff", "kl_target", "target_network_update_freq",
             "tau", "target_worker_clipping", "use_circular_buffer", "circular_buffer_num_batches",
             "circular_buffer_iterations_per_batch", "simple_queue_size", "use_critic"),
    "SAC": ("twin_q", "q_model_config", "policy_model_config", "tau", "initial_alpha", "target_entropy", "n_step",
            "store_buffer_in_checkpoints", "replay_buffer_config", "training_intensity", "clip_actions",
            "optimization_config", "actor_lr", "critic_lr", "alpha_lr", "target_network_update_freq",
            "_deterministic_loss", "_use_beta_distribution", "num_steps_sampled_before_learning_starts"),
}

OLD_NAMES: dict[str, str] = {
    "num_sgd_iter": "num_epochs", "sgd_minibatch_size": "minibatch_size", "num_rollout_workers": "num_env_runners",
    "num_envs_per_worker": "num_envs_per_env_runner", "evaluation_num_workers": "evaluation_num_env_runners",
    "recreate_failed_workers": "restart_failed_env_runners", "recreate_failed_env_runners":
    "restart_failed_env_runners", "ignore_worker_failures": "ignore_env_runner_failures",
    "num_learner_workers": "num_learners", "num_cpus_per_worker": "num_cpus_per_env_runner",
    "num_gpus_per_worker": "num_gpus_per_env_runner", "create_env_on_local_worker": "create_local_env_runner",
    "model_config_dict": "model_config", "lambda": "lambda_", "input": "input_", "callbacks": "callbacks_class",
    "max_num_worker_restarts": "max_num_env_runner_restarts",
}
"""Old-stack names RLlib 2.x still accepts -> the name they set (``to_dict`` writes ``lambda`` and ``input``)."""

DEFAULTS: dict[str, Any] = {
    "env": None, "env_config": {}, "observation_space": None, "action_space": None, "render_env": False,
    "clip_rewards": None, "normalize_actions": True, "clip_actions": False, "disable_env_checking": False,
    "action_mask_key": "action_mask",
    "gamma": 0.99, "lr": 0.001, "grad_clip": None, "grad_clip_by": "global_norm", "train_batch_size": 32,
    "train_batch_size_per_learner": None, "num_epochs": 1, "minibatch_size": None, "shuffle_batch_per_epoch": False,
    "model": {}, "optimizer": {}, "learner_class": None, "learner_connector": None, "lr_schedule": None,
    "num_env_runners": 0, "num_envs_per_env_runner": 1, "rollout_fragment_length": "auto",
    "batch_mode": "truncate_episodes", "explore": True, "env_runner_cls": None, "env_to_module_connector": None,
    "module_to_env_connector": None, "observation_filter": "NoFilter",
    "num_learners": 0, "num_gpus_per_learner": 0, "num_gpus": 0,
    "evaluation_interval": None, "evaluation_duration": 10, "evaluation_duration_unit": "episodes",
    "evaluation_config": None, "evaluation_num_env_runners": 0, "custom_evaluation_function": None,
    "evaluation_parallel_to_training": False,
    "metrics_num_episodes_for_smoothing": 100, "min_time_s_per_iteration": None,
    "min_sample_timesteps_per_iteration": 0, "min_train_timesteps_per_iteration": 0,
    "framework": "torch", "log_level": "WARN", "seed": None,
    "policies": None, "policy_mapping_fn": None, "policies_to_train": None,
    "model_config": {}, "rl_module_spec": None, "callbacks_class": None,
    "restart_failed_env_runners": True, "ignore_env_runner_failures": False,
    "enable_rl_module_and_learner": True, "enable_env_runner_and_connector_v2": True, "input_": "sampler",
    "output": None,
}
"""AlgorithmConfig's defaults of the keys the face reads or checks (any other key defaults to None)."""

ALGO_DEFAULTS: dict[str, dict[str, Any]] = {
    "PPO": {"lr": 5e-5, "train_batch_size": 4000, "num_epochs": 30, "minibatch_size": 128,
            "shuffle_batch_per_epoch": True, "num_env_runners": 2, "use_critic": True, "use_gae": True,
            "lambda_": 1.0, "use_kl_loss": True, "kl_coeff": 0.2, "kl_target": 0.01, "vf_loss_coeff": 1.0,
            "entropy_coeff": 0.0, "entropy_coeff_schedule": None, "clip_param": 0.3, "vf_clip_param": 10.0,
            "model_config": {"vf_share_layers": False}},
    "DQN": {"lr": 5e-4, "train_batch_size": 32, "target_network_update_freq": 500,
            "replay_buffer_config": {"type": "PrioritizedEpisodeReplayBuffer", "capacity": 50000, "alpha": 0.6,
                                     "beta": 0.4},
            "num_steps_sampled_before_learning_starts": 1000, "n_step": 1, "double_q": True, "dueling": True,
            "hiddens": [256], "epsilon": [(0, 1.0), (10000, 0.05)], "training_intensity": None, "tau": 1.0,
            "td_error_loss_fn": "huber", "grad_clip": 40.0, "min_sample_timesteps_per_iteration": 1000,
            "noisy": False, "num_atoms": 1, "num_env_runners": 0},
    "SAC": {"lr": None, "train_batch_size": 256, "train_batch_size_per_learner": 256, "twin_q": True, "tau": 5e-3,
            "initial_alpha": 1.0, "target_entropy": "auto", "n_step": 1,
            "replay_buffer_config": {"type": "PrioritizedEpisodeReplayBuffer", "capacity": 1_000_000, "alpha": 0.6,
                                     "beta": 0.4},
            "training_intensity": None, "clip_actions": False, "actor_lr": 3e-5, "critic_lr": 3e-4,
            "alpha_lr": 3e-4, "grad_clip": None, "target_network_update_freq": 0,
            "num_steps_sampled_before_learning_starts": 1500, "min_time_s_per_iteration": 1,
            "min_sample_timesteps_per_iteration": 100, "_deterministic_loss": False,
            "_use_beta_distribution": False, "num_env_runners": 0,
            "q_model_config": {"fcnet_hiddens": [256, 256], "fcnet_activation": "relu", "post_fcnet_hiddens": [],
                               "post_fcnet_activation": None, "custom_model": None, "custom_model_config": {}},
            "policy_model_config": {"fcnet_hiddens": [256, 256], "fcnet_activation": "relu",
                                    "post_fcnet_hiddens": [], "post_fcnet_activation": None, "custom_model": None,
                                    "custom_model_config": {}}},
    "IMPALA": {"vtrace": True, "vtrace_clip_rho_threshold": 1.0, "vtrace_clip_pg_rho_threshold": 1.0,
               "learner_queue_size": 3, "broadcast_interval": 1, "grad_clip": 40.0, "grad_clip_by": "global_norm",
               "vf_loss_coeff": 0.5, "entropy_coeff": 0.01, "num_learners": 1, "rollout_fragment_length": 50,
               "train_batch_size": 500, "num_env_runners": 2, "lr": 5e-4, "min_time_s_per_iteration": 10,
               "opt_type": "adam", "entropy_coeff_schedule": None, "lr_schedule": None, "decay": 0.99,
               "momentum": 0.0, "epsilon": 0.1, "_separate_vf_optimizer": False, "_lr_vf": 5e-4},
    "APPO": {"vtrace": True, "vtrace_clip_rho_threshold": 1.0, "vtrace_clip_pg_rho_threshold": 1.0,
             "learner_queue_size": 16, "broadcast_interval": 1, "grad_clip": 40.0, "grad_clip_by": "global_norm",
             "vf_loss_coeff": 0.5, "entropy_coeff": 0.01, "num_learners": 1, "rollout_fragment_length": 50,
             "train_batch_size": 500, "num_env_runners": 2, "lr": 5e-4, "min_time_s_per_iteration": 10,
             "opt_type": "adam", "entropy_coeff_schedule": None, "lr_schedule": None, "decay": 0.99,
             "momentum": 0.0, "epsilon": 0.1, "_separate_vf_optimizer": False, "_lr_vf": 5e-4,
             "use_gae": True, "lambda_": 1.0, "clip_param": 0.4, "use_kl_loss": False, "kl_coeff": 1.0,
             "kl_target": 0.01, "target_worker_clipping": 2.0, "use_circular_buffer": True,
             "circular_buffer_num_batches": 8, "circular_buffer_iterations_per_batch": 2, "simple_queue_size": 32,
             "target_network_update_freq": 2, "tau": 1.0, "use_critic": None,
             "model_config": {"vf_share_layers": False}},
}
"""Each algorithm's own defaults over :data:`DEFAULTS` (RLlib 2.60's ``PPOConfig.__init__``)."""

DEFAULT_MODEL: dict[str, Any] = {
    "fcnet_hiddens": [256, 256], "fcnet_activation": "tanh", "fcnet_kernel_initializer": None,
    "fcnet_kernel_initializer_kwargs": None, "fcnet_bias_initializer": None, "fcnet_bias_initializer_kwargs": None,
    "fcnet_use_layernorm": False, "conv_filters": None, "conv_activation": "relu", "conv_kernel_initializer": None,
    "conv_kernel_initializer_kwargs": None, "conv_bias_initializer": None, "conv_bias_initializer_kwargs": None,
    "head_fcnet_hiddens": [], "head_fcnet_activation": "relu", "head_fcnet_kernel_initializer": None,
    "head_fcnet_kernel_initializer_kwargs": None, "head_fcnet_bias_initializer": None,
    "head_fcnet_bias_initializer_kwargs": None, "head_fcnet_use_layernorm": False, "free_log_std": False,
    "log_std_clip_param": 20.0, "vf_share_layers": True, "use_lstm": False, "max_seq_len": 20,
    "lstm_cell_size": 256, "lstm_use_prev_action": False, "lstm_use_prev_reward": False,
    "lstm_kernel_initializer": None, "lstm_kernel_initializer_kwargs": None, "lstm_bias_initializer": None,
    "lstm_bias_initializer_kwargs": None, "fusionnet_hiddens": [256, 256], "fusionnet_activation": "tanh",
    "fusionnet_kernel_initializer": None, "fusionnet_kernel_initializer_kwargs": None,
    "fusionnet_bias_initializer": None, "fusionnet_bias_initializer_kwargs": None,
}
"""RLlib's ``DefaultModelConfig`` fields and defaults (``rl_module(model_config=...)``)."""

OLD_MODEL_KEYS = ("custom_model", "custom_model_config", "custom_action_dist", "custom_preprocessor", "dim",
                  "grayscale", "zero_mean", "framestack", "post_fcnet_hiddens", "post_fcnet_activation",
                  "no_final_linear", "use_attention", "attention_dim", "lstm_use_prev_action_reward",
                  "_disable_preprocessor_api", "_disable_action_flattening", "_time_major",
                  "_use_default_native_models", "always_check_shapes", "fcnet_weights_initializer",
                  "encoder_latent_dim")
"""Old-stack ``model={...}`` keys beyond DefaultModelConfig's (accepted names; see translate.MODEL_UNSUPPORTED)."""

UNSUPPORTED: dict[str, str] = {
    "learner_class": "RLlib's Learner subclasses are not run: rlchain's PPO loss options are config keys "
                     "(docs/rllib.md)",
    "learner_connector": "connectors are not run: preprocess observations in a gymnasium wrapper",
    "env_to_module_connector": "only MeanStdFilter() (normalize_input) and FlattenObservations() are mapped; "
                               "preprocess observations in a gymnasium wrapper",
    "module_to_env_connector": "connectors are not run: postprocess actions in a gymnasium wrapper",
    "env_runner_cls": "rlchain steps the envs itself (docs/rllib.md)",
    "input_": "offline RL is not in rlchain; train on an env",
    "output": "offline RL is not in rlchain (rlchain writes TensorBoard and checkpoints)",
    "use_critic": "rlchain's PPO always trains a critic",
    "entropy_coeff_schedule": "rlchain's entropy schedule: train with entropy_coeff as a number",
    "lr_schedule": "a constant lr (a list schedule is not mapped)",
    "_torch_lr_scheduler_classes": "torch schedulers run in RLlib's Learner, which the face does not run: give lr "
                                   "as RLlib's schedule list [[0, lr0], [env_steps, lr1], ...]",
    "_torch_grad_scaler_class": "RLlib's Learner-side grad scaler is not run (the face trains in float32)",
    "framework": "rlchain is PyTorch only (framework='torch')",
    "observation_filter": "rlchain's observation normalizer is normalize_input (not mapped from RLlib)",
}
"""Keys whose non-default value the face refuses, with what to use instead."""

UNSUPPORTED_VALUES: dict[str, tuple[Any, ...]] = {"framework": ("torch",), "use_critic": (True, None),
                                                  "input_": ("sampler",), "output": (None,)}
"""Values of :data:`UNSUPPORTED` keys that are fine (default: only the key's default)."""


def all_keys(algo: str) -> dict[str, str]:
    """Every accepted key name of ``algo`` -> the builder method that takes it."""
    out = {key: method for method, keys in METHOD_KEYS.items() for key in keys}
    out.update({key: "training" for key in ALGO_TRAINING_KEYS.get(algo, ())})
    return out


def defaults(algo: str) -> dict[str, Any]:
    """RLlib's defaults for ``algo`` (a fresh copy)."""
    import copy
    return copy.deepcopy({**DEFAULTS, **ALGO_DEFAULTS.get(algo, {})})
