"""rl_games' modules rlchain does not offer, in one table: importing one through ``rl_games`` (the alias,
:mod:`rlchain.rl_games.alias`) is an ImportError whose one line says what it is and what to use instead.

Agent code (``a2c_continuous``, ``a2c_discrete``, ``sac_agent``, ``central_value``, ``a2c_common``, and 2.0's
``datasets``, the agent's minibatch slicer): rlchain trains those algorithms with its own loop.
"""

from __future__ import annotations

INSTEAD = ("rlchain trains {algo} with its own loop (params.algo.name: {algo}, through runner.py or "
           "rl_games' Runner); networks and models written for rl_games (network_builder.A2CBuilder, "
           "models.ModelA2C*) train there as registered; an agent subclass (IsaacGymEnvs' AMP, common_agent) "
           "needs porting to an rlchain algorithm registered with model_builder.register_algo (docs/rl_games.md)")

NOT_OFFERED = {
    "rl_games.algos_torch.a2c_continuous": ("A2CAgent", "a2c_continuous"),
    "rl_games.algos_torch.a2c_discrete": ("DiscreteA2CAgent", "a2c_discrete"),
    "rl_games.algos_torch.sac_agent": ("SACAgent", "sac"),
    "rl_games.algos_torch.central_value": ("CentralValueTrain", "a2c_continuous"),
    "rl_games.common.a2c_common": ("A2CBase, ContinuousA2CBase, DiscreteA2CBase", "a2c_continuous"),
    "rl_games.common.datasets": ("PPODataset, DatasetList", "a2c_continuous"),
}
"""rl_games module -> (the classes it defines, the algorithm rlchain trains in its place)."""


def not_offered_message(name: str) -> str | None:
    """The one-line ImportError message of rl_games module ``name`` (``rl_games.X.Y``), or None when rlchain
    offers it."""
    found = NOT_OFFERED.get(name)
    if found is None:
        return None
    classes, algo = found
    return f"{name} ({classes}) is rl_games' agent code, not offered by rlchain: " + INSTEAD.format(algo=algo)
