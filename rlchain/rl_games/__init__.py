"""rl_games' Python API on rlchain: the module names and signatures rl_games scripts import.

A script written against rl_games (Isaac Lab's and IsaacGymEnvs' ``train.py`` / ``play.py``) imports

    from rl_games.common import env_configurations, vecenv
    from rl_games.common.algo_observer import IsaacAlgoObserver
    from rl_games.torch_runner import Runner

This package offers the same names (``rlchain.rl_games.torch_runner.Runner``,
``rlchain.rl_games.common.{vecenv, env_configurations, algo_observer, player}``,
``rlchain.rl_games.algos_torch.{model_builder, network_builder, torch_ext, players}``), each built on
rlchain's own parts: the Runner trains with rlchain's loop, ``vecenv.register`` and
``env_configurations.register`` fill rlchain's registries, observers ride rlchain's callback events.
``python -m rlchain.rl_games SCRIPT [ARGS...]`` runs such a script unchanged, with ``import rl_games``
resolving here (:mod:`rlchain.rl_games.alias`). See docs/rl_games.md.
"""

from rlchain.version import __version__

__all__ = ["__version__"]
