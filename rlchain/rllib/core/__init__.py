"""``ray.rllib.core``: RLlib's column names and module ids."""

DEFAULT_MODULE_ID = "default_policy"
DEFAULT_POLICY_ID = "default_policy"
ALL_MODULES = "__all_modules__"
COMPONENT_RL_MODULE = "rl_module"
COMPONENT_LEARNER_GROUP = "learner_group"
COMPONENT_LEARNER = "learner"
COMPONENT_ENV_RUNNER = "env_runner"
