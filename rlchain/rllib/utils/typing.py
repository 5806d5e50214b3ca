"""``ray.rllib.utils.typing``: RLlib's type aliases (annotations only: each is ``Any``, or the container it names,
so a module annotated with them imports and runs)."""

from typing import Any, TypeVar

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
T = TypeVar("T")

# RLlib 2.60's other aliases, read by user modules only as annotations.
_OTHERS = ("TensorShape", "NetworkType", "DeviceType", "RLModuleSpecType", "PartialAlgorithmConfigDict",
           "ConvFilterSpec", "FromConfigSpec", "EnvConfigDict", "EnvCreator", "MultiAgentPolicyConfigDict",
           "EpisodeType", "IsPolicyToTrain", "AgentToModuleMappingFn", "ShouldModuleBeUpdatedFn", "PolicyState",
           "TFPolicyV2Type", "EpisodeID", "UnrollID", "MultiEnvDict", "EnvObsType", "EnvActionType", "EnvInfoDict",
           "FileType", "ViewRequirementsDict", "LocalOptimizer", "Optimizer", "Param", "ParamRef", "ParamDict",
           "ParamList", "NamedParamDict", "LearningRateOrSchedule", "GradInfoDict", "LearnerStatsDict",
           "ModelGradients", "ModelWeights", "ModelInputDict", "SampleBatchType", "SpaceStruct", "StateBatches",
           "PolicyOutputType", "AgentConnectorDataType", "ActionConnectorDataType", "AgentConnectorsOutput")
globals().update(dict.fromkeys(_OTHERS, Any))

__all__ = ["AgentID", "AlgorithmConfigDict", "EnvID", "EnvType", "ModelConfigDict", "ModuleID", "MultiAgentDict",
           "PolicyID", "ResultDict", "StateDict", "T", "TensorStructType", "TensorType", *_OTHERS]
