"""``ray.rllib.utils.typing``: RLlib's type aliases (annotations only)."""

from typing import Any

TensorType = Any
TensorStructType = Any
AgentID = Any
PolicyID = str
ModuleID = str
EnvType = Any
EnvID = Any
MultiAgentDict = dict
ResultDict = dict
StateDict = dict
ModelConfigDict = dict
AlgorithmConfigDict = dict

__all__ = ["AgentID", "AlgorithmConfigDict", "EnvID", "EnvType", "ModelConfigDict", "ModuleID", "MultiAgentDict",
           "PolicyID", "ResultDict", "StateDict", "TensorStructType", "TensorType"]
