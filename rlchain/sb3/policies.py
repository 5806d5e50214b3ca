"""SB3's ``stable_baselines3.common.policies`` names on rlchain: ``from rlchain.sb3.policies import
ActorCriticPolicy`` (the class lives in :mod:`rlchain.networks.sb3_policies`)."""

from rlchain.networks.sb3_policies import ActorCriticCnnPolicy, ActorCriticPolicy, MultiInputActorCriticPolicy

__all__ = ["ActorCriticPolicy", "ActorCriticCnnPolicy", "MultiInputActorCriticPolicy"]
