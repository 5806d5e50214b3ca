"""rl_games' ``common.layers``: the recurrent layers its networks build (``recurrent``)."""
