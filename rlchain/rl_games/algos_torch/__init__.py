"""rl_games' ``rl_games.algos_torch``: model and network registration, torch helpers, players."""
