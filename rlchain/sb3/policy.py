"""``model.policy`` as SB3 has it: the rlchain network under SB3's parameter names, with ``predict`` and ``save``.

:class:`SB3Policy` holds the rlchain network (``policy.net``, rlchain's names) and shows it the way SB3's
``ActorCriticPolicy`` / ``SACPolicy`` / ``DQNPolicy`` look: ``state_dict()`` under SB3's names
(:mod:`rlchain.sb3.names`: ``mlp_extractor.policy_net.0.weight``, ``action_net``, ``value_net``, ``log_std``,
``actor``, ``critic``, ``q_net``), ``load_state_dict`` taking SB3's names or rlchain's (``strict=False`` loads a
part, as SB3's parameter-access example does), ``predict`` as SB3's, and ``save(path)`` writing SB3's policy file
(``{'state_dict', 'data'}``) that SB3's ``MlpPolicy.load`` reads.
"""

from __future__ import annotations

import os
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from torch import nn

from rlchain.envs.wrappers.spaces import flatten_dict_obs
from rlchain.inference.export.onnx import export_model_onnx, obs_dtype
from rlchain.sb3.names import from_sb3, is_sb3_named, to_sb3

TORCH_ACTIVATIONS = {"tanh": nn.Tanh, "relu": nn.ReLU, "elu": nn.ELU, "selu": nn.SELU, "swish": nn.SiLU,
                     "gelu": nn.GELU, "softplus": nn.Softplus, "sigmoid": nn.Sigmoid, "None": nn.Identity}
"""rl_games' activation names -> the torch.nn classes SB3's ``activation_fn`` takes."""


OUTSIDE_SB3_POLICY = ("log_alpha",)
"""rlchain state that SB3 keeps outside its policy's state dict (SAC's entropy coefficient)."""


def constant_schedule(progress_remaining: float) -> float:
    """The ``lr_schedule`` a saved policy file carries (SB3's constructors need one; loading for inference
    never calls it)."""
    return 0.0


def predict_actions(net: nn.Module, space: Any, observation: Any, deterministic: bool) -> np.ndarray:
    """``(actions, one)`` of ``net`` for one observation or a batch (a Dict observation flattened as in
    training); ``net`` is put in eval mode for the call and back (the live policy during ``learn``)."""
    if isinstance(observation, dict) and hasattr(space, "dict_space"):
        parts = {k: np.asarray(v, dtype=np.float32) for k, v in observation.items()}
        first = next(iter(space.dict_space.spaces))
        one = parts[first].shape == space.dict_space.spaces[first].shape
        observation = flatten_dict_obs({k: v[None] if one else v for k, v in parts.items()}, space.dict_space)
        observation = observation[0] if one else observation
    obs = np.asarray(observation, dtype=np.float32)
    single = obs.shape == tuple(space.shape)
    device = next(net.parameters()).device
    batch = torch.as_tensor(obs[None] if single else obs.reshape(-1, *space.shape), device=device)
    actions = eval_actions(net, batch, deterministic)
    return actions[0] if single else actions


def eval_actions(net: nn.Module, batch: Any, deterministic: bool) -> np.ndarray:
    """The env actions of ``net`` for a batch of observations (a tensor or a per-key ObsDict), with ``net`` in
    eval mode for the call and put back (the live policy during ``learn``)."""
    was_training = net.training
    net.eval()
    try:
        with torch.inference_mode():
            actions = net.dist.to_env(net.act(batch, deterministic=deterministic)["actions"])
    finally:
        net.train(was_training)
    return actions.cpu().numpy()


class SACActorView(nn.Module):
    """SB3's SAC ``actor`` over rlchain's SAC model: ``forward(obs, deterministic)`` -> actions in [-1, 1] (the
    model's image scaling and input normalization included). It holds the actor network and the normalizer only,
    so tracing it (SB3's export guide: ONNX, ``torch.jit.trace``) sees nothing of the critics."""

    def __init__(self, model: nn.Module) -> None:
        super().__init__()
        self.actor = model.network.actor
        self.obs_norm = model.running_mean_std
        self._model = [model]  # not a submodule: the stochastic path and Dict observations use it

    @property
    def model(self) -> nn.Module:
        return self._model[0]

    def forward(self, obs: torch.Tensor, deterministic: bool = False) -> torch.Tensor:
        trunk = getattr(self.actor, "trunk", None)
        head = trunk[-1] if isinstance(trunk, nn.Sequential) and len(trunk) else None  # the (mean, log-std) layer
        if not deterministic or not isinstance(obs, torch.Tensor) or not isinstance(head, nn.Linear):
            return self.model.policy(self.model.preprocess(obs), deterministic)[0]
        x = obs.float() / 255.0 if obs.dtype == torch.uint8 else obs.float()
        x = x.flatten(1)
        if self.obs_norm is not None:
            x = self.obs_norm.normalize(x)
        actor = self.actor
        x = actor.encoder(x) if getattr(actor, "encoder", None) is not None else x
        # tanh(mean), the mean read by slicing the output layer's rows (mean, then log-std): ONNX exporters handle a
        # slice where torch.chunk's Split may not convert to older opsets
        mu = actor.trunk(x)[..., :head.out_features // 2]
        if actor.mean_clip is not None:
            mu = mu.clamp(-actor.mean_clip, actor.mean_clip)
        return torch.tanh(mu)


class SB3Policy(nn.Module):
    """See the module docstring. ``network`` is the config's network block (for ``save``'s ``data``)."""

    def __init__(self, net: nn.Module, algo: str, observation_space: Any, action_space: Any,
                 network: dict[str, Any] | None = None) -> None:
        super().__init__()
        self.net = net
        self.algo = algo
        self.observation_space = observation_space
        self.action_space = action_space
        self.network = dict(network or {})

    def state_dict(self, *args: Any, **kwargs: Any) -> dict[str, torch.Tensor]:  # type: ignore[override]
        """The network's parameters and buffers under SB3's names (SAC's temperature is not part of SB3's
        policy: it stays out, as the rest of the model's state does)."""
        state = to_sb3(self.algo, self.net.state_dict(*args, **kwargs))
        return {k: v for k, v in state.items() if k not in OUTSIDE_SB3_POLICY}

    def load_state_dict(self, state_dict: Any, strict: bool = True, assign: bool = False) -> Any:
        """Load SB3-named (or rlchain-named) tensors into the network; what SB3's policy lacks
        (:data:`OUTSIDE_SB3_POLICY`) keeps its value."""
        if is_sb3_named(self.algo, state_dict):
            current = self.net.state_dict()
            state_dict = {**{k: current[k] for k in OUTSIDE_SB3_POLICY if k in current},
                          **from_sb3(self.algo, state_dict, current)}
        return self.net.load_state_dict(state_dict, strict=strict, assign=assign)

    def forward(self, obs: torch.Tensor, deterministic: bool = False) -> Any:
        """SB3's ``policy(obs, deterministic)``: PPO ``(actions, values, log_prob)``; SAC the actions in [-1, 1]
        (before rescaling to the bounds); DQN the greedy (or epsilon) actions. Traceable (``torch.onnx.export``
        of a module calling it, as SB3's export guide does)."""
        if self.algo == "ppo":
            params, value, _ = self.net.evaluate(obs)
            dist = self.net.dist
            actions = dist.mode(params) if deterministic else dist.sample(params)
            return actions, self.net.denorm_value(value), dist.log_prob(params, actions)
        if self.algo == "sac":
            return self.net.policy(self.net.preprocess(obs), deterministic)[0]
        return self.net.act(obs, deterministic=deterministic)["actions"]

    @property
    def actor(self) -> nn.Module:
        """SAC: SB3's ``policy.actor``, called as ``actor(obs, deterministic=True)`` -> actions in [-1, 1]."""
        if self.algo != "sac":
            raise AttributeError(f"{self.algo.upper()}'s policy has no actor (SAC's has)")
        return SACActorView(self.net)

    def __getattr__(self, name: str) -> Any:
        """An attribute of a user's policy class (``features_extractor``, ``mlp_extractor``, ``action_net``, ...)
        when the network is one (the sb3_policy network's ``policy``)."""
        try:
            return super().__getattr__(name)
        except AttributeError:
            net = self._modules.get("net")
            inner = getattr(net, "a2c_network", None) or getattr(net, "network", None)  # PPO's, SAC / DQN's
            policy = getattr(inner, "policy", None) if isinstance(inner, nn.Module) else None
            if isinstance(policy, nn.Module) and hasattr(policy, name):
                return getattr(policy, name)
            raise

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = False) -> tuple[np.ndarray, Any]:
        """``(actions, None)`` as SB3's ``policy.predict`` (MlpPolicy has no recurrent state); Box actions clipped
        to the action space's bounds, as SB3 clips them."""
        actions = predict_actions(self.net, self.observation_space, observation, deterministic)
        if isinstance(self.action_space, gym.spaces.Box):
            actions = np.clip(actions, self.action_space.low, self.action_space.high)
        return actions, None

    def set_training_mode(self, mode: bool) -> None:
        """SB3's name for ``train(mode)``."""
        self.net.train(mode)

    def export_onnx(self, path: str) -> str:
        """The deterministic policy (an actor-critic network) as an ONNX graph; returns the path."""
        space = self.observation_space
        return export_model_onnx(self.net, tuple(space.shape), path, input_dtype=obs_dtype(space))

    def save(self, path: str) -> None:
        """SB3's policy file: ``torch.save({'state_dict': ..., 'data': constructor arguments}, path)`` (SB3's
        ``MlpPolicy.load(path)`` rebuilds the policy from it)."""
        mlp = self.network.get("mlp", {})
        units = list(mlp.get("units", [64, 64]))
        data: dict[str, Any] = {"observation_space": self.observation_space, "action_space": self.action_space,
                                "lr_schedule": constant_schedule,
                                "activation_fn": TORCH_ACTIVATIONS.get(str(mlp.get("activation", "tanh")), nn.Tanh)}
        if self.algo == "ppo":
            data["net_arch"] = {"pi": units, "vf": units}
            data["ortho_init"] = False  # the weights come from state_dict
        elif self.algo == "sac":
            data["net_arch"] = {"pi": units, "qf": units}
        else:
            data["net_arch"] = units
        torch.save({"state_dict": self.state_dict(), "data": data}, os.fspath(path))
