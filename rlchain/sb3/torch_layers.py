"""SB3's ``stable_baselines3.common.torch_layers`` names on rlchain: ``from rlchain.sb3.torch_layers import
BaseFeaturesExtractor`` (the classes live in :mod:`rlchain.networks.sb3_extractors`)."""

from rlchain.networks.sb3_extractors import (
                                             BaseFeaturesExtractor,
                                             CombinedExtractor,
                                             FlattenExtractor,
                                             MlpExtractor,
                                             NatureCNN,
                                             create_mlp,
)

__all__ = ["BaseFeaturesExtractor", "CombinedExtractor", "FlattenExtractor", "MlpExtractor", "NatureCNN",
           "create_mlp"]
