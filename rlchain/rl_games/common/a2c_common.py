"""rl_games' ``a2c_common``: its agent code is not offered (see :mod:`rlchain.rl_games.agents`)."""

from rlchain.rl_games.agents import refuse

refuse(__name__, "A2CBase, ContinuousA2CBase, DiscreteA2CBase", "a2c_continuous")
