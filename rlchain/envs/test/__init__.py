"""Small test environments (rl_games' test envs and more) so every feature can be tried in seconds.

Each module registers its envs with gymnasium or :data:`rlchain.registry.ENVS` when imported;
:mod:`rlchain.builtins` imports this package.
"""

from rlchain.envs.test import (  # noqa: F401  (each module registers its envs)
    asymmetric,
    cooperative,
    duel,
    embodichain_standins,
    goal_reach,
    masked,
    masked_velocity,
    multidiscrete,
    rnn_env,
)
