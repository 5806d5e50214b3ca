"""``ray.rllib.connectors.env_to_module``: ``MeanStdFilter`` (rlchain's ``normalize_input``) and
``FlattenObservations`` (the face's observations are already flat); RLlib's other
env-to-module connectors are each a one-line ImportError saying what to write instead. Any other name is an
AttributeError, as on any module: ``hasattr`` / ``getattr(module, name, default)`` and pickle's search of every
loaded module for an object's name (``pickle.whichmodule``, which torch.compile's cache key runs) read it as
"no such attribute"."""

from typing import Any

from rlchain.rllib.connectors.env_to_module.flatten_observations import FlattenObservations
from rlchain.rllib.connectors.env_to_module.mean_std_filter import MeanStdFilter
from rlchain.rllib.face_error import FaceImportError

__all__ = ["FlattenObservations", "MeanStdFilter"]

NOT_OFFERED = frozenset({
    "AddObservationsFromEpisodesToBatch", "AddStatesFromEpisodesToBatch", "AddTimeDimToBatchAndZeroPad",
    "AgentToModuleMapping", "BatchIndividualItems", "EnvToModulePipeline", "NumpyToTensor",
    "PrevActionsPrevRewards", "WriteObservationsToEpisodes"})
"""RLlib 2.60's other ``env_to_module`` connectors (its ``__all__`` less MeanStdFilter and FlattenObservations)."""


def __getattr__(name: str) -> Any:
    if name not in NOT_OFFERED:
        raise AttributeError(f"module 'ray.rllib.connectors.env_to_module' has no attribute '{name}'")
    raise FaceImportError(f"ray.rllib.connectors.env_to_module.{name} is not offered by rlchain's RLlib face: "
                          f"only MeanStdFilter and FlattenObservations are; preprocess observations in a gymnasium "
                          f"wrapper",
                          name="ray.rllib.connectors.env_to_module")
