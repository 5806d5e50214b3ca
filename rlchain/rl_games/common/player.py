"""rl_games' ``BasePlayer``: a trained policy that a script steps itself (Isaac Lab's ``play.py``).

    agent = runner.create_player()
    agent.restore(checkpoint)
    agent.reset()
    obs = env.reset()
    agent.get_batch_size(obs["obs"], 1)
    if agent.is_rnn:
        agent.init_rnn()
    actions = agent.get_action(agent.obs_to_torch(obs), is_deterministic=agent.is_deterministic)

``policy`` is rlchain's model (built from the config's network block, as training built it), ``model`` the same
modules under rl_games' names (for SAC, rl_games' SAC model); ``restore`` reads an rlchain checkpoint. The env's
spaces come from the ``env_configurations`` entry of ``env_name`` (its ``env_creator``, or its vector env with
``player.use_vecenv``), as rl_games finds them, else from the env rlchain builds for the config. :meth:`run`
plays ``player.games_num`` games itself (``runner.run({'play': True})``).
"""

from __future__ import annotations

import copy
from types import SimpleNamespace
from typing import Any

import numpy as np
import torch

from rlchain.config.load import parse_params
from rlchain.config.params import Params
from rlchain.envs.factory import build_env
from rlchain.envs.gym_spaces import spaces_to_gymnasium
from rlchain.models.build import apply_sigma
from rlchain.parallel.device import resolve_device
from rlchain.policy.load import load_policy, load_weights
from rlchain.policy.play import play
from rlchain.registry import ENVS
from rlchain.rl_games.common import env_configurations, vecenv
from rlchain.runs import checkpoint as ckpt


def parse_player_params(params: dict[str, Any]) -> Params:
    """rl_games' ``params`` dict validated by rlchain (its ``env_info`` / ``vec_env`` objects set aside)."""
    config = {k: v for k, v in (params.get("config") or {}).items() if k not in ("env_info", "vec_env", "stop_fn")}
    raw = {k: v for k, v in params.items() if k not in ("env", "load_checkpoint", "load_path", "config")}
    return parse_params(copy.deepcopy({"params": {**raw, "config": config}}), "<params>")


class BasePlayer:
    """A policy built from ``params`` (rl_games' ``params`` dict, parsed by rlchain as ``parsed``; built as
    rl_games builds a player, ``Player(params)``, when ``parsed`` is not given)."""

    def __init__(self, params: dict[str, Any], parsed: Params | None = None) -> None:
        parsed = parse_player_params(params) if parsed is None else parsed
        self.params = params
        self.parsed = parsed
        cfg = parsed.config
        self.config = params.get("config", {})
        self.env_name = cfg.env_name
        self.player_config = self.config.get("player", {}) or {}
        self.env_config = dict(self.player_config.get("env_config", self.config.get("env_config", {})) or {})
        self.seed = self.env_config.pop("seed", parsed.seed)
        self.device = resolve_device(cfg.device)
        self.device_name = str(self.device)
        self.is_deterministic = bool(cfg.player.deterministic)
        self.games_num = int(cfg.player.games_num)
        self.render_env = bool(cfg.player.render)
        self.clip_actions = bool(cfg.clip_actions)
        self.env = None
        given = self.config.get("env_info")
        if given is not None:  # rl_games: the spaces given, the env (if any) from config['vec_env']
            self.env = self.config.get("vec_env")
        self.env_info = spaces_to_gymnasium(dict(given if given is not None else self._env_info()))
        self.num_agents = int(self.env_info.get("agents", 1))
        self.value_size = int(self.env_info.get("value_size", 1))
        self.action_space = self.env_info["action_space"]
        self.observation_space = self.env_info["observation_space"]
        spaces = self.observation_space.spaces if hasattr(self.observation_space, "spaces") else None
        self.obs_shape = ({k: v.shape for k, v in spaces.items()} if isinstance(spaces, dict)
                          else self.observation_space.shape)
        shape = SimpleNamespace(observation_space=self.observation_space, action_space=self.action_space,
                                value_size=self.value_size)
        # rlchain's model, which acts and takes the weights (no weights yet: restore() loads them); ``model`` is
        # the same modules under rl_games' names for the algorithm (see rl_games_model)
        self.policy = load_policy(parsed, device=self.device, env=shape).model
        self.is_rnn = bool(getattr(self.policy, "is_rnn", False))
        self.normalize_input = getattr(self.policy, "running_mean_std", None) is not None
        self.model = self.rl_games_model(self.policy)
        self.states: list[torch.Tensor] | None = None
        self.batch_size = 1
        self.has_batch_dimension = False
        self.is_tensor_obses = False

    def rl_games_model(self, policy: torch.nn.Module) -> torch.nn.Module:
        """``player.model`` as rl_games' PPO players hold it: rlchain's model with the names rl_games' ONNX recipe
        reads: ``a2c_network`` (the network with rl_games' ``forward(input_dict)`` contract, the model's own) and
        ``norm_obs`` (input normalization; a plain attribute, not an extra state_dict key)."""
        object.__setattr__(policy, "norm_obs", policy.preprocess)
        return policy

    def _env_info(self) -> dict[str, Any]:
        """The spaces as rl_games finds them: the env_configurations entry's env, else rlchain's env."""
        if self.config.get("vec_env") is not None:  # rl_games: the env given in the config
            self.env = self.config["vec_env"]
            return env_configurations.get_env_info(self.env)
        entry = ENVS.get(self.env_name) if self.env_name in ENVS else {}
        if self.player_config.get("use_vecenv", False) and "vecenv_type" in entry:
            self.env = vecenv.create_vec_env(self.env_name, self.parsed.config.player.num_actors, **self.env_config)
            return env_configurations.get_env_info(self.env)
        if "env_creator" in entry:
            self.env = entry["env_creator"](**self.env_config)
            return env_configurations.get_env_info(self.env)
        env = build_env(self.parsed, 1, self.seed)
        try:
            return {"observation_space": env.observation_space, "action_space": env.action_space,
                    "agents": getattr(env, "num_agents", 1), "value_size": getattr(env, "value_size", 1)}
        finally:
            env.close()

    # ----- weights ------------------------------------------------------------------------------------
    def restore(self, fn: str) -> None:
        """Load the policy of an rlchain checkpoint (a mismatched one is a one-line CheckpointError)."""
        load_weights(self.policy, fn, self.device)

    def get_weights(self) -> dict[str, Any]:
        """``{'model': state_dict}`` (normalizers included)."""
        return {"model": self.policy.state_dict()}

    def set_weights(self, weights: dict[str, Any]) -> None:
        """Load what :meth:`get_weights` returned."""
        self.policy.load_state_dict(weights["model"])

    def override_sigma(self, sigma: float) -> None:
        """A fixed sigma set to ``sigma`` (``run({'sigma': ...})``)."""
        apply_sigma(self.policy, sigma)

    # ----- stepping -----------------------------------------------------------------------------------
    def reset(self) -> None:
        """New episodes everywhere: the RNN states start from zero."""
        self.init_rnn()

    def init_rnn(self) -> None:
        """Zero RNN states for ``batch_size`` envs (``states``: a list of (layers, batch, units) tensors)."""
        if self.is_rnn:
            self.states = [s.clone() for s in self.policy.initial_state(self.batch_size, self.device)]

    def get_batch_size(self, obses: Any, batch_size: int) -> int:
        """The batch of ``obses`` (its first dim when it has one beyond the observation's shape), kept as
        ``batch_size`` for :meth:`init_rnn`."""
        obs_shape = self.obs_shape
        if isinstance(obses, dict):
            obses = obses.get("obs", obses)
        if isinstance(obs_shape, dict):
            key = "observation" if "observation" in obs_shape else next(iter(obs_shape))
            obs_shape, obses = obs_shape[key], obses[key] if isinstance(obses, dict) else obses
        if len(np.shape(obses)) > len(obs_shape):
            batch_size = int(np.shape(obses)[0])
            self.has_batch_dimension = True
        self.batch_size = batch_size
        return batch_size

    def cast_obs(self, obs: Any) -> torch.Tensor:
        """An observation as a tensor on the player's device (uint8 kept, other numbers float32)."""
        if isinstance(obs, torch.Tensor):
            self.is_tensor_obses = True
            return obs.to(self.device)
        array = np.asarray(obs)
        tensor = torch.as_tensor(array if array.dtype == np.uint8 else array.astype(np.float32))
        return tensor.to(self.device)

    def obs_to_torch(self, obs: Any) -> Any:
        """``obs`` (or ``obs['obs']``) as tensors on the device; a dict of tensors for dict observations."""
        if isinstance(obs, dict) and "obs" in obs:
            obs = obs["obs"]
        if isinstance(obs, dict):
            return {k: self.cast_obs(v) for k, v in obs.items()}
        return self.cast_obs(obs)

    def get_action(self, obs: Any, is_deterministic: bool = False) -> torch.Tensor:
        """Actions for ``obs`` (one observation, or a batch after :meth:`get_batch_size`): the
        distribution's mode when ``is_deterministic``, else a sample; continuous actions clipped and
        rescaled to the action space with ``clip_actions`` (as rl_games returns them)."""
        return self._act(obs, is_deterministic, None)

    def get_masked_action(self, obs: Any, mask: Any, is_deterministic: bool = False) -> torch.Tensor:
        """:meth:`get_action` under action masks ``mask`` (B, mask_size) bool."""
        return self._act(obs, is_deterministic, mask)

    def _act(self, obs: Any, is_deterministic: bool, mask: Any) -> torch.Tensor:
        """What :meth:`get_action` and :meth:`get_masked_action` return (``mask`` None: no action masks)."""
        obs = self.obs_to_torch(obs)
        if isinstance(obs, dict):
            raise ValueError("get_action: dict observations other than {'obs': ...} are flattened by rlchain's "
                             "env backends; pass the flat observation")
        batched = self.has_batch_dimension or obs.dim() > len(self.obs_shape)
        if not batched:
            obs = obs.unsqueeze(0)
        # a recurrent model takes its states; SAC's model has no ``states`` argument
        kwargs = {"states": tuple(self.states) if self.states else None} if self.is_rnn else {}
        if mask is not None:
            kwargs["action_masks"] = torch.as_tensor(mask, device=self.device).bool().reshape(obs.shape[0], -1)
        out = self.policy.act(obs, deterministic=is_deterministic, **kwargs)
        if self.is_rnn:
            self.states = list(out["states"])
        actions = self.policy.dist.to_env(out["actions"])
        return actions if batched else actions.squeeze(0)

    def run(self) -> Any:
        """Play ``player.games_num`` games on the env rlchain builds for the config (``player.num_actors``
        envs with ``use_vecenv``, else one); prints and returns the PlayResult."""
        pc = self.parsed.config.player
        env = build_env(self.parsed, pc.num_actors if pc.use_vecenv else 1, self.seed, render=pc.render,
                        env_config=pc.env_config)
        try:  # the model as training built it for this env ([obs | state] rows of a central-value env)
            model = load_policy(self.parsed, device=self.device, env=env, eval_mode=False).model
            weights = self.policy.state_dict()
            if getattr(self.policy, ckpt.NORMS_DROPPED, False):  # built as rl_games 1.6.5 built the restored file
                ckpt.drop_unbuilt_norms(model)
            model.load_state_dict(weights)
            result = play(model, env, self.games_num, self.is_deterministic, device=self.device, seed=self.seed)
        finally:
            env.close()
        print(f"av reward: {result.mean_reward:.2f} av steps: {result.mean_length:.1f} over {result.games} games",
              flush=True)
        return result


__all__ = ["BasePlayer"]
