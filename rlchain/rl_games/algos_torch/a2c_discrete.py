"""rl_games' ``a2c_discrete``: its agent code is not offered (see :mod:`rlchain.rl_games.agents`)."""

from rlchain.rl_games.agents import refuse

refuse(__name__, "DiscreteA2CAgent", "a2c_discrete")
