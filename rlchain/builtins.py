"""Registration of every built-in algo, model, network and env: the one place it happens. Envs and vector envs
go through the doors users have (``env_configurations.register``, ``vecenv.register``)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from rlchain import env_configurations
from rlchain.algos.apg.apg import APG
from rlchain.algos.appo.appo import APPO, IMPALA
from rlchain.algos.distill.distill import Distill
from rlchain.algos.grpo.grpo import GRPO
from rlchain.algos.off_policy.dqn import DQN
from rlchain.algos.off_policy.dqn_agent import dqn_model
from rlchain.algos.off_policy.sac import SAC, soft_actor_critic_model
from rlchain.algos.ppo.ppo import PPO
from rlchain.envs import examples, vecenv
from rlchain.envs.backends import atari, mujoco_push, torch_envs
from rlchain.envs.backends.mjlab_env import mjlab_env, mjlab_vecenv
from rlchain.envs.building import BUILTIN_ENVS, VECENV_ALIASES, VECENV_TYPES
from rlchain.envs.examples import embodichain_standins
from rlchain.envs.factory import BuiltinVecEnv
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import make_distribution
from rlchain.networks.actor_critic import ActorCriticBuilder
from rlchain.networks.example_networks import TestNet, TestNetAuxLoss
from rlchain.networks.multi_input import multi_input_network
from rlchain.networks.resnet_actor_critic import resnet_actor_critic_network
from rlchain.networks.sac_network import q_network, sac_network
from rlchain.networks.sb3_policy import sb3_policy_network
from rlchain.registry import ALGOS, MODELS, NETWORKS, WRITERS
from rlchain.runs.writers import CSVWriter


def actor_critic_model(network: Any, action_space: Any, obs_shape: tuple, value_size: int, config: Any,
                       model_name: str) -> ActorCritic:
    """The model presets discrete_a2c / multi_discrete_a2c / continuous_a2c_logstd / continuous_a2c."""
    dist = make_distribution(model_name, action_space, config.clip_actions, network)
    masks = getattr(config, "use_action_masks", False)  # PPO's keys; another algorithm's config may lack them
    if masks and not dist.mask_size:
        raise ValueError(f"params.config.use_action_masks: needs discrete or multi-discrete actions, the env has "
                         f"{action_space}")
    kind = getattr(config, "value_normalizer", "rl_games")  # a user algorithm's config class may not have the key
    return ActorCritic(network, dist, obs_shape, value_size, config.normalize_input,
                       getattr(config, "normalize_value", False), use_action_masks=masks, value_normalizer_kind=kind,
                       obs_normalizer_kind=getattr(config, "obs_normalizer", "rl_games"),
                       obs_normalizer_exclude=tuple(getattr(config, "obs_normalizer_exclude", ())),
                       bptt_length=getattr(config, "bptt_length", None))


def register_builtins() -> None:

    for name in ("discrete_a2c", "multi_discrete_a2c", "continuous_a2c_logstd", "continuous_a2c"):
        MODELS.register(name, actor_critic_model, overwrite=True)
    NETWORKS.register("actor_critic", ActorCriticBuilder, overwrite=True)
    NETWORKS.register("multi_input", multi_input_network, overwrite=True)
    NETWORKS.register("sb3_policy", sb3_policy_network, overwrite=True)  # SB3 users' extractors and policy classes

    # rl_games' test networks; a user package may register its own under these names (as in rl_games)
    NETWORKS.register("testnet", TestNet, overwrite=True, replaceable=True)
    NETWORKS.register("testnet_aux_loss", TestNetAuxLoss, overwrite=True, replaceable=True)
    NETWORKS.register("resnet_actor_critic", resnet_actor_critic_network, overwrite=True)
    for name in ("a2c_continuous", "a2c_discrete"):
        ALGOS.register(name, PPO, overwrite=True)

    MODELS.register("soft_actor_critic", soft_actor_critic_model, overwrite=True)
    MODELS.register("dqn", dqn_model, overwrite=True)
    NETWORKS.register("soft_actor_critic", sac_network, overwrite=True)
    NETWORKS.register("dqn", q_network, overwrite=True)
    ALGOS.register("sac", SAC, overwrite=True)
    ALGOS.register("dqn", DQN, overwrite=True)

    ALGOS.register("appo", APPO, overwrite=True)
    ALGOS.register("impala", IMPALA, overwrite=True)
    ALGOS.register("distill", Distill, overwrite=True)
    ALGOS.register("grpo", GRPO, overwrite=True)
    ALGOS.register("apg", APG, overwrite=True)
    # envs through the two doors users have: env_configurations.register (batched envs: a vecenv_creator)
    for name, builder in {**BUILTIN_ENVS, **atari.ENV_BUILDERS, **torch_envs.ENV_BUILDERS, **examples.ENV_BUILDERS,
                          **embodichain_standins.ENV_BUILDERS,
                          **mujoco_push.ENV_BUILDERS, "mjlab": mjlab_env}.items():  # mjlab: imported when built
        env_configurations.register(name, {"vecenv_creator": builder}, overwrite=True)
    # and vecenv.register: vecenv_type names, rl_games' creator signature; RAY / ENVPOOL match case-insensitively;
    # rl_games 2.0's vecenv_type MJLAB
    for name, mode in [*((m, m) for m in VECENV_TYPES), *VECENV_ALIASES.items()]:
        vecenv.register(name, BuiltinVecEnv(mode), overwrite=True)
    vecenv.register("mjlab", mjlab_vecenv, overwrite=True)
    # gymnasium ids (a lookup of env_name, not a registry of rlchain's): Atari with the DeepMind preprocessing,
    # the example envs
    gym_ids = {atari.ATARI_ID: (atari.make_atari_env, {"disable_env_checker": True}), **examples.GYM_ENVS}
    for env_id, (entry_point, kwargs) in gym_ids.items():
        if env_id not in gym.registry:
            gym.register(env_id, entry_point=entry_point, **kwargs)
    WRITERS.register("csv", CSVWriter, overwrite=True, replaceable=True)  # a user package may register its own
