"""rl_games' modules rlchain does not offer, in one table: importing one through ``rl_games`` (the alias,
:mod:`rlchain.rl_games.alias`) is an ImportError whose one line says what it is and what to use instead.

Agent code (``a2c_continuous``, ``a2c_discrete``, ``sac_agent``, ``central_value``, ``a2c_common``, and 2.0's
``datasets``, the agent's minibatch slicer): rlchain trains those algorithms with its own loop.
"""

from __future__ import annotations

from typing import Any

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

RLCHAIN_PBT = ("rlchain's population-based training is Ray Tune's PBT: `rlchain train CONFIG --tune SEARCH.yaml` "
               "with `backend: ray` and a PBT scheduler (docs/tuning.md); rl_games.common.pbt's MultiObserver, PbtCfg "
               "and PbtAlgoObserver are offered")

OTHER = {
    "rl_games.common.pbt.pbt": ("rl_games' re-exec PBT", RLCHAIN_PBT),
    "rl_games.common.pbt.pbt_utils": ("rl_games' PBT checkpoints and restarts", RLCHAIN_PBT),
    "rl_games.common.pbt.mutation": ("rl_games' PBT mutations", RLCHAIN_PBT),
    "rl_games.common.pbt.mutate": ("rl_games' PBT mutation function", RLCHAIN_PBT),
    "rl_games.common.pbt.pbt_cfg": ("PbtCfg", "import it from rl_games.common.pbt"),
    "rl_games.algos_torch.moving_mean_std": (
        "GeneralizedMovingStats, the advantage statistics inside rl_games' PPO agent",
        "rlchain's PPO keeps them itself under the same keys (normalize_rms_advantage, adv_rms_momentum)"),
    "rl_games.common.diagnostics": ("PpoDiagnostics, rl_games' agent diagnostics",
                                    "rlchain's PPO writes its own statistics to TensorBoard"),
    "rl_games.triton_config": ("rl_games' Triton switch", "rlchain computes GAE in its own PPO (no Triton)"),
    "rl_games.triton_kernels": ("rl_games' Triton GAE kernels", "rlchain computes GAE in its own PPO (no Triton)"),
    "rl_games.common.gymnasium_vecenv": ("rl_games' gymnasium vec env class",
                                         "env_name: gymnasium (env_config.env_name) builds it in a config"),
}
"""Other rl_games modules rlchain does not offer -> (what they hold, what to use); a name under one (a
submodule) gets its message too."""


def not_offered_message(name: str) -> str | None:
    """The one-line ImportError message of rl_games module ``name`` (``rl_games.X.Y``), or None when rlchain
    offers it."""
    found = NOT_OFFERED.get(name)
    if found is not None:
        classes, algo = found
        return f"{name} ({classes}) is rl_games' agent code, not offered by rlchain: " + INSTEAD.format(algo=algo)
    parts = name.split(".")
    for end in range(len(parts), 1, -1):
        other = OTHER.get(".".join(parts[:end]))
        if other is not None:
            return f"{name} ({other[0]}) is not offered by rlchain: {other[1]}"
    return None


def package_getattr(package: str, name: str) -> Any:
    """The module ``__getattr__`` of rlchain's stand-in for rl_games package ``package``: ``from
    rl_games.<package> import <module>`` of a module rlchain does not offer is its one-line ImportError (Python
    resolves such a name under rlchain's own module name, so the alias alone would say only "cannot import
    name"); any other missing name is an AttributeError."""
    message = not_offered_message(f"{package}.{name}")
    if message is not None:
        raise ImportError(message, name=f"{package}.{name}")
    raise AttributeError(f"module '{package}' has no attribute '{name}'")
