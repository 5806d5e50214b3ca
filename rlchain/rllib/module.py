"""RLlib's RLModule view of rlchain's trained policy: ``algo.get_module()`` with ``forward_inference``,
``forward_exploration``, ``forward_train`` ({"obs": batch} -> {"action_dist_inputs": ...}) and
``compute_values``, plus RLlib's ``DefaultModelConfig`` and ``RLModuleSpec`` as data."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from rlchain.envs.obs_dict import ObsDict
from rlchain.rllib import keys as K
from rlchain.rllib.face_error import FaceNotOffered

ACTION_DIST_INPUTS = "action_dist_inputs"
VF_PREDS = "vf_preds"
NAME_PREFIX = "rllib_module_"
"""Network names registered for users' RLModule classes start so (a checkpoint's YAML naming one needs the module
class in the script)."""


@dataclass
class DefaultModelConfig:
    """RLlib 2.60's default model settings (``rl_module(model_config=DefaultModelConfig(...))``), every field of
    RLlib's class; what the face maps is in docs/rllib.md (the initializers and ``fusionnet_*`` are kept and have
    no effect: rlchain's default initialization, no fusion net)."""

    fcnet_hiddens: list[int] = field(default_factory=lambda: [256, 256])
    fcnet_activation: str = "tanh"
    fcnet_kernel_initializer: Any = None
    fcnet_kernel_initializer_kwargs: Any = None
    fcnet_bias_initializer: Any = None
    fcnet_bias_initializer_kwargs: Any = None
    fcnet_use_layernorm: bool = False
    conv_filters: Any = None
    conv_activation: str = "relu"
    conv_kernel_initializer: Any = None
    conv_kernel_initializer_kwargs: Any = None
    conv_bias_initializer: Any = None
    conv_bias_initializer_kwargs: Any = None
    head_fcnet_hiddens: list[int] = field(default_factory=list)
    head_fcnet_activation: str = "relu"
    head_fcnet_kernel_initializer: Any = None
    head_fcnet_kernel_initializer_kwargs: Any = None
    head_fcnet_bias_initializer: Any = None
    head_fcnet_bias_initializer_kwargs: Any = None
    head_fcnet_use_layernorm: bool = False
    free_log_std: bool = False
    log_std_clip_param: float = 20.0
    vf_share_layers: bool = True
    use_lstm: bool = False
    max_seq_len: int = 20
    lstm_cell_size: int = 256
    lstm_use_prev_action: bool = False
    lstm_use_prev_reward: bool = False
    lstm_kernel_initializer: Any = None
    lstm_kernel_initializer_kwargs: Any = None
    lstm_bias_initializer: Any = None
    lstm_bias_initializer_kwargs: Any = None
    fusionnet_hiddens: list[int] = field(default_factory=lambda: [256, 256])
    fusionnet_activation: str = "tanh"
    fusionnet_kernel_initializer: Any = None
    fusionnet_kernel_initializer_kwargs: Any = None
    fusionnet_bias_initializer: Any = None
    fusionnet_bias_initializer_kwargs: Any = None


assert {f.name for f in dataclasses.fields(DefaultModelConfig)} == set(K.DEFAULT_MODEL)


@dataclass
class RLModuleSpec:
    """RLlib's module spec; the face reads ``model_config`` only (a ``module_class`` is refused in one line)."""

    module_class: Any = None
    observation_space: Any = None
    action_space: Any = None
    inference_only: bool = False
    learner_only: bool = False
    model_config: Any = None
    catalog_class: Any = None
    load_state_path: Any = None


class RLModuleView:
    """The trained policy under RLlib's module calls (torch in, torch out; no gradient)."""

    framework = "torch"

    def __init__(self, model: Any, observation_space: Any, action_space: Any) -> None:
        self.model = model
        self.observation_space = observation_space
        self.action_space = action_space
        self._q_model = hasattr(model, "q_values")  # DQN's QModel: forward -> (Q (B, n), max Q)

    def _obs(self, batch: dict[str, Any]) -> Any:
        obs = batch["obs"]
        device = next(iter([*self.model.parameters(), *self.model.buffers()]), torch.zeros(0)).device
        if isinstance(obs, dict):  # a Dict observation, kept per key as the run's model takes it
            return ObsDict({k: self._tensor(v, device) for k, v in obs.items()})
        return self._tensor(obs, device)

    @staticmethod
    def _tensor(value: Any, device: torch.device) -> torch.Tensor:
        return torch.as_tensor(np.asarray(value) if not isinstance(value, torch.Tensor) else value,
                               dtype=torch.float32, device=device)

    @torch.no_grad()
    def forward_inference(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, torch.Tensor]:
        """{"obs": (B, *obs_shape)} -> {"action_dist_inputs": (B, P)}: logits (discrete), or means then log-stds
        (continuous, as RLlib's diagonal Gaussian)."""
        params, _ = self.model(self._obs(batch))
        if self._q_model:  # DQN: the Q-values are the action-distribution inputs (argmax is the greedy action)
            return {ACTION_DIST_INPUTS: params, "qf_preds": params}
        return {ACTION_DIST_INPUTS: self._rllib_params(params)}

    forward_exploration = forward_inference

    def forward_train(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, torch.Tensor]:
        out = self.forward_inference(batch)
        out[VF_PREDS] = self.compute_values(batch)
        return out

    @torch.no_grad()
    def compute_values(self, batch: dict[str, Any], embeddings: Any = None) -> torch.Tensor:
        """The critic's values (B,) in the returns' scale (DQN: max Q)."""
        if self._q_model:
            return self.model(self._obs(batch))[1][..., 0]
        return self.model.value(self._obs(batch))[..., 0]

    def _rllib_params(self, params: torch.Tensor) -> torch.Tensor:
        dist = self.model.dist
        if not dist.continuous:
            return params
        mu, std = params.chunk(2, dim=-1)  # rlchain's Gaussian params are cat(mu, std)
        return torch.cat([mu, torch.log(std)], -1)

    @torch.no_grad()
    def act(self, obs: Any, explore: bool) -> Any:
        """One action for one observation (numpy / int), sampled or the mode."""
        one = {k: np.asarray(v)[None] for k, v in obs.items()} if isinstance(obs, dict) else np.asarray(obs)[None]
        params, _ = self.model(self._obs({"obs": one}))
        if self._q_model:  # greedy (exploration in training is the run's epsilon)
            return int(params.argmax(-1)[0])
        dist = self.model.dist
        action = dist.sample(params) if explore else dist.mode(params)
        out = dist.to_env(action)[0].cpu().numpy()
        return int(out) if out.ndim == 0 else out

    def state_dict(self) -> dict[str, Any]:
        return self.model.state_dict()

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        raise FaceNotOffered("the old ModelV2 call model({'obs': ...}) is not offered: use the RLModule's "
                             "forward_inference({'obs': batch})['action_dist_inputs'] (algo.get_module())")

    def get_state(self) -> dict[str, Any]:
        return {k: v.cpu().numpy() for k, v in self.model.state_dict().items()}

    def eval(self) -> RLModuleView:
        return self

    def is_stateful(self) -> bool:
        return bool(getattr(self.model, "is_rnn", False))


class OldPolicy:
    """RLlib's older Policy object (``algo.get_policy()``): ``model`` is the module and ``compute_single_action``
    returns (action, states, extras)."""

    def __init__(self, module: RLModuleView) -> None:
        self.model = module

    def compute_single_action(self, obs: Any = None, state: Any = None, explore: bool | None = None,
                              **kwargs: Any) -> Any:
        return self.model.act(obs, True if explore is None else bool(explore)), [], {}

    def export_model(self, export_dir: str, onnx: int | None = None) -> None:
        raise FaceNotOffered("Policy.export_model is the old API stack's: export the module with "
                             "torch.onnx.export(algo.get_module().model, ...) or save it with algo.save_to_path")
