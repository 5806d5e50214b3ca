"""``ray.rllib.core.rl_module.apis``: the APIs a module declares by subclassing them."""

from rlchain.rllib.core.rl_module.apis.value_function_api import ValueFunctionAPI


class InferenceOnlyAPI:
    """RLlib's marker API: the attributes an inference-only copy of the module leaves out."""

    def get_non_inference_attributes(self) -> list[str]:
        return []


TARGET_NETWORK_ACTION_DIST_INPUTS = "target_network_action_dist_inputs"
"""The output key of a module's target network (RLlib's name)."""


class TargetNetworkAPI:
    """RLlib's target-network API (off-policy modules): not trained by the face."""


__all__ = ["TARGET_NETWORK_ACTION_DIST_INPUTS", "InferenceOnlyAPI", "TargetNetworkAPI", "ValueFunctionAPI"]
