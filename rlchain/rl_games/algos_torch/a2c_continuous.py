"""rl_games' ``a2c_continuous``: its agent code is not offered (see :mod:`rlchain.rl_games.agents`)."""

from rlchain.rl_games.agents import refuse

refuse(__name__, "A2CAgent", "a2c_continuous")
