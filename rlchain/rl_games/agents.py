"""rl_games' agent modules (``a2c_continuous``, ``a2c_discrete``, ``sac_agent``, ``central_value``,
``a2c_common``): not offered. rlchain trains those algorithms with its own loop; importing one of them is an
ImportError whose one line says so and what to use instead."""

from __future__ import annotations

INSTEAD = ("rlchain trains {algo} with its own loop (params.algo.name: {algo}, through runner.py or "
           "rl_games' Runner); networks and models written for rl_games (network_builder.A2CBuilder, "
           "models.ModelA2C*) train there as registered; an agent subclass (IsaacGymEnvs' AMP, common_agent) "
           "needs porting to an rlchain algorithm registered with model_builder.register_algo (docs/rl_games.md)")


def refuse(module: str, classes: str, algo: str) -> None:
    """Raise the ImportError of rl_games' agent module ``module`` (defining ``classes``, training ``algo``)."""
    name = module.replace("rlchain.rl_games", "rl_games", 1)
    raise ImportError(f"{name} ({classes}) is rl_games' agent code, not offered by rlchain: "
                      + INSTEAD.format(algo=algo), name=name)
