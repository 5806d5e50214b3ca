"""Registration of every built-in algo, model and network: the one place it happens."""

from __future__ import annotations

from typing import Any

import rlchain.envs.backends.atari  # noqa: F401  (registers atari_gym and rl_games' Atari preset names)
import rlchain.envs.backends.torch_envs  # noqa: F401  (registers the TorchCartPole/Pendulum/Reacher8 tensor envs)
import rlchain.envs.test  # noqa: F401  (registers the test envs)
from rlchain.algos.apg.trainer import APGTrainer
from rlchain.algos.appo.trainer import APPOTrainer, ImpalaTrainer
from rlchain.algos.distill.trainer import DistillTrainer
from rlchain.algos.grpo.trainer import GRPOTrainer
from rlchain.algos.off_policy.dqn import dqn_model
from rlchain.algos.off_policy.sac import soft_actor_critic_model
from rlchain.algos.off_policy.trainer import DQNTrainer, SACTrainer
from rlchain.algos.ppo.trainer import OnPolicyTrainer
from rlchain.envs.building import BUILTIN_ENVS, VECENV_ALIASES, VECENV_TYPES
from rlchain.envs.factory import BuiltinVecEnv
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import make_distribution
from rlchain.networks.actor_critic import ActorCriticBuilder
from rlchain.networks.resnet_actor_critic import ResnetActorCriticBuilder
from rlchain.networks.sac_network import QNetworkBuilder, SACNetworkBuilder
from rlchain.networks.test_networks import TestNetAuxLossBuilder, TestNetBuilder
from rlchain.registry import ALGOS, ENVS, MODELS, NETWORKS, VECENVS, WRITERS
from rlchain.runs.writers import CSVWriter


def actor_critic_model(network: Any, action_space: Any, obs_shape: tuple, value_size: int, config: Any,
                       model_name: str) -> ActorCritic:
    """The model presets discrete_a2c / multi_discrete_a2c / continuous_a2c_logstd / continuous_a2c."""
    dist = make_distribution(model_name, action_space, config.clip_actions, network)
    if config.use_action_masks and not dist.mask_size:
        raise ValueError(f"params.config.use_action_masks: needs discrete or multi-discrete actions, the env has "
                         f"{action_space}")
    kind = getattr(config, "value_normalizer", "rl_games")  # a user algorithm's config class may not have the key
    return ActorCritic(network, dist, obs_shape, value_size, config.normalize_input, config.normalize_value,
                       use_action_masks=config.use_action_masks, value_normalizer_kind=kind)


def register_builtins() -> None:

    for name in ("discrete_a2c", "multi_discrete_a2c", "continuous_a2c_logstd", "continuous_a2c"):
        MODELS.register(name, actor_critic_model, overwrite=True)
    NETWORKS.register("actor_critic", ActorCriticBuilder, overwrite=True)

    # rl_games' test networks; a user package may register its own under these names (as in rl_games)
    NETWORKS.register("testnet", TestNetBuilder, overwrite=True, replaceable=True)
    NETWORKS.register("testnet_aux_loss", TestNetAuxLossBuilder, overwrite=True, replaceable=True)
    NETWORKS.register("resnet_actor_critic", ResnetActorCriticBuilder, overwrite=True)
    for name in ("a2c_continuous", "a2c_discrete"):
        ALGOS.register(name, OnPolicyTrainer, overwrite=True)

    MODELS.register("soft_actor_critic", soft_actor_critic_model, overwrite=True)
    MODELS.register("dqn", dqn_model, overwrite=True)
    NETWORKS.register("soft_actor_critic", SACNetworkBuilder, overwrite=True)
    NETWORKS.register("dqn", QNetworkBuilder, overwrite=True)
    ALGOS.register("sac", SACTrainer, overwrite=True)
    ALGOS.register("dqn", DQNTrainer, overwrite=True)

    ALGOS.register("appo", APPOTrainer, overwrite=True)
    ALGOS.register("impala", ImpalaTrainer, overwrite=True)
    ALGOS.register("distill", DistillTrainer, overwrite=True)
    ALGOS.register("grpo", GRPOTrainer, overwrite=True)
    ALGOS.register("apg", APGTrainer, overwrite=True)
    for name, builder in BUILTIN_ENVS.items():
        ENVS.register(name, builder, overwrite=True)
    # vecenv_type names, rl_games' creator signature; RAY / ENVPOOL match case-insensitively
    for name, mode in [*((m, m) for m in VECENV_TYPES), *VECENV_ALIASES.items()]:
        VECENVS.register(name, BuiltinVecEnv(mode), overwrite=True)
    WRITERS.register("csv", CSVWriter, overwrite=True, replaceable=True)  # a user package may register its own
