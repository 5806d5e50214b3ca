"""``ray.rllib.core``: RLlib's column names and module ids (the face's one definition of the default module id)."""

from rlchain.rllib.core.columns import Columns as Columns  # RLlib's examples import it from here too

DEFAULT_MODULE_ID = "default_policy"
DEFAULT_POLICY_ID = DEFAULT_MODULE_ID  # the old stack's name of the same id
ALL_MODULES = "__all_modules__"
COMPONENT_RL_MODULE = "rl_module"
COMPONENT_LEARNER_GROUP = "learner_group"
COMPONENT_LEARNER = "learner"
COMPONENT_ENV_RUNNER = "env_runner"
