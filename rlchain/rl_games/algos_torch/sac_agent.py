"""rl_games' ``sac_agent``: its agent code is not offered (see :mod:`rlchain.rl_games.agents`)."""

from rlchain.rl_games.agents import refuse

refuse(__name__, "SACAgent", "sac")
