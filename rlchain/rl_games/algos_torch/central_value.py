"""rl_games' ``central_value``: its agent code is not offered (see :mod:`rlchain.rl_games.agents`)."""

from rlchain.rl_games.agents import refuse

refuse(__name__, "CentralValueTrain", "a2c_continuous")
