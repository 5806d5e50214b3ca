"""rl_games' ``rl_games.common``: vec envs, env configurations, observers, the player base class."""
