"""rl_games' test networks ``testnet`` and ``testnet_aux_loss``: try an auxiliary loss in seconds.

The same contract as the networks rl_games registers from ``rl_games/envs/test_network.py``
(written anew for rlchain). They read the Dict observations of ``TestRnnEnv-v0`` with
``env_config.multi_obs_space: True``: keys ``pos`` (2,) and ``info`` (4,), plus ``aux_target``
(1,) for ``testnet_aux_loss`` (``env_config.aux_loss: True``). ``pos`` and ``info`` are
concatenated and go through three ReLU layers (256, 128, 64) to a categorical head and a value
head. The actor returns ``(logits, value, None)``; built with ``central_value: True`` (a critic
under ``config.central_value_config.network``) it returns ``(value, None)``.

``testnet_aux_loss`` also predicts ``aux_target`` (the squared distance to the goal, scaled)
from the last hidden layer. Its ``get_aux_loss()`` returns ``{'aux_dist_loss': MSE}`` of the
last forward pass, which PPO adds to its loss and logs as ``losses/aux_dist_loss``: the
template for a user network with auxiliary losses.

Each class is registered as it is (built as ``TestNet(params_network, **kwargs)``). rlchain hands every
network flat observations; these networks get the env's Dict space as the
``observation_space`` keyword and take each key's columns back out of the flat vector.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import torch
import torch.nn as nn
import torch.nn.functional as F

AUX_TARGET = "aux_target"


def key_columns(space: Any, keys: tuple[str, ...], network: str, path: str = "") -> dict[str, slice]:
    """Columns of each of ``keys`` in the flat vector of a Dict ``space`` (gymnasium's flatten order).

    Raises a one-line ValueError (starting with ``path``, if given) when ``space`` is not a Dict
    with those keys.
    """
    spaces = space.spaces if isinstance(space, gym.spaces.Dict) else {}
    missing = [key for key in keys if key not in spaces]
    if missing:
        where = f"{path}: " if path else ""
        raise ValueError(f"{where}{network} reads Dict observations with keys {', '.join(keys)} (rl_games' "
                         f"TestRnnEnv-v0 with env_config.multi_obs_space: True"
                         f"{', aux_loss: True' if AUX_TARGET in keys else ''}); the env gives {space}")
    columns, start = {}, 0
    for key, sub in spaces.items():
        size = int(gym.spaces.flatdim(sub))
        columns[key] = slice(start, start + size)
        start += size
    return {key: columns[key] for key in keys}


class TestNet(nn.Module):
    """``testnet``: Dict ``pos`` + ``info`` -> 256 -> 128 -> 64 (ReLU) -> logits and value."""

    __test__ = False  # not a pytest test class
    network_name = "testnet"
    keys: tuple[str, ...] = ("pos", "info")

    def __init__(self, params: Any, *, actions_num: int, observation_space: Any, value_size: int = 1,
                 action_space: Any = None, **kwargs: Any) -> None:
        super().__init__()
        self.central_value = bool(_get(params, "central_value", False))
        name = _get(params, "name", self.network_name)
        path = "" if self.central_value else "params.network"  # the critic's errors get their path in build.py
        if not self.central_value and isinstance(action_space, gym.spaces.Box):
            raise ValueError(f"{path}.name: {name} has a categorical head (Discrete or MultiDiscrete actions); "
                             f"the env's actions are {action_space}")
        self.columns = key_columns(observation_space, self.keys, name, path)
        inputs = sum(self.columns[key].stop - self.columns[key].start for key in ("pos", "info"))
        self.linear1 = nn.Linear(inputs, 256)
        self.linear2 = nn.Linear(256, 128)
        self.linear3 = nn.Linear(128, 64)
        self.mean_linear = nn.Linear(64, actions_num)
        self.value_linear = nn.Linear(64, value_size)

    def is_rnn(self) -> bool:
        return False

    def features(self, obs: torch.Tensor) -> torch.Tensor:
        """Flat observations (B, flatdim) -> the last hidden layer (B, 64)."""
        x = torch.cat([obs[:, self.columns["pos"]], obs[:, self.columns["info"]]], dim=-1)
        x = F.relu(self.linear1(x))
        x = F.relu(self.linear2(x))
        return F.relu(self.linear3(x))

    def heads(self, x: torch.Tensor) -> tuple:
        """rl_games' output tuple from the last hidden layer."""
        value = self.value_linear(x)
        if self.central_value:
            return value, None
        return self.mean_linear(x), value, None

    def forward(self, input_dict: dict) -> tuple:
        return self.heads(self.features(input_dict["obs"]))


class TestNetAuxLoss(TestNet):
    """``testnet_aux_loss``: :class:`TestNet` plus a head predicting ``aux_target``, trained by
    the auxiliary loss ``aux_dist_loss`` (MSE) that :meth:`get_aux_loss` hands to PPO."""

    network_name = "testnet_aux_loss"
    keys = ("pos", "info", AUX_TARGET)

    def __init__(self, params: Any, **kwargs: Any) -> None:
        super().__init__(params, **kwargs)
        target = self.columns[AUX_TARGET]
        self.aux_loss_linear = nn.Linear(64, target.stop - target.start)
        self.aux_dist_loss: torch.Tensor | None = None  # from the last forward pass

    def get_aux_loss(self) -> dict[str, torch.Tensor | None]:
        """rl_games' hook: the auxiliary losses of the last forward pass (None before the first)."""
        return {"aux_dist_loss": self.aux_dist_loss}

    def forward(self, input_dict: dict) -> tuple:
        obs = input_dict["obs"]
        x = self.features(obs)
        self.aux_dist_loss = F.mse_loss(self.aux_loss_linear(x), obs[:, self.columns[AUX_TARGET]])
        return self.heads(x)


def _get(params: Any, key: str, default: Any) -> Any:
    """A key of the network block: a dict (user builders get the raw block) or an object."""
    if isinstance(params, dict):
        return params.get(key, default)
    return getattr(params, key, default)
