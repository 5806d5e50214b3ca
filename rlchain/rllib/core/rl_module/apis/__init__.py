"""``ray.rllib.core.rl_module.apis``: the APIs a module declares by subclassing them."""

from rlchain.rllib.core.rl_module.apis.value_function_api import ValueFunctionAPI


class InferenceOnlyAPI:
    """RLlib's marker API: the attributes an inference-only copy of the module leaves out."""

    def get_non_inference_attributes(self) -> list[str]:
        return []


class TargetNetworkAPI:
    """RLlib's target-network API (off-policy modules): not trained by the face."""


__all__ = ["InferenceOnlyAPI", "TargetNetworkAPI", "ValueFunctionAPI"]
