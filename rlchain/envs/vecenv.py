"""The VecEnv contract every backend implements.

Shapes for ``num_envs = N``:

- ``reset(seed) -> obs``: obs (N, *observation_space.shape), numpy array or torch tensor.
- ``step(actions) -> StepResult``: actions (N, *action_space.shape) numpy array.
  ``obs`` is the observation to act on next: for an env whose episode just ended it is already
  the first observation of the next episode (same-step auto-reset). The true last observation of
  the ended episode is in ``final_obs`` at that row (rows of envs that did not end hold
  anything). ``reward`` (N,) float32, ``terminated`` and ``truncated`` (N,) bool, kept apart:
  truncation is a time-out, not a terminal state.
- ``game_reward`` / ``game_over`` (optional, (N,) float32 / bool, None when absent): for envs whose
  training episode is not the whole game (Atari with episodic life: ``terminated`` at each lost
  life) or whose ``reward`` is clipped, the game's own reward and the end of the whole game. Episode
  statistics, ``score_to_win`` and the Player count games with them (:func:`game_outcome`).
- ``observation_space`` / ``action_space``: the single-env gymnasium spaces.
- tensor envs set ``is_tensor_env = True`` and ``device``: ``step`` then takes a torch tensor of
  actions on that device and every StepResult field is a tensor on it (no numpy round trip).
- ``steps_on_torch_threads = True`` (optional; rlchain's tensor envs): the env steps with torch ops
  in this process and has no threads of its own, so on a CPU the rollout takes as many torch
  threads as the update (envpool's and subprocess envs' threads need the other cores instead).
- optional rl_games attributes: ``value_size`` (default 1), ``get_number_of_agents()`` (1),
  ``use_central_value`` (False), ``has_action_mask()`` (False). rlchain reads these (and the other
  optional parts below) once, into the :class:`~rlchain.envs.spec.EnvSpec` the factory attaches as
  ``env.env_spec``.
- multi-agent envs (``get_number_of_agents() > 1``) come through ``multi_agent.py``: one row per
  agent, so ``num_envs`` already counts the agents (``num_agents`` rows per env, ``num_actors`` envs).
- self-play envs: ``set_opponent(policy, env_ids)`` and optionally ``pop_scores()`` (training/self_play.py).
- action masks (``params.config.use_action_masks``): ``has_action_mask() -> bool`` and
  ``get_action_mask()`` -> (N, mask_size) bool, numpy array or (tensor envs) a tensor on
  ``device``, True where an action is allowed in the env's current state (after ``reset`` and
  after every ``step``, auto-reset rows included). ``mask_size`` is n for Discrete(n) and
  sum(nvec) for MultiDiscrete / Tuple of Discrete (per-dimension masks concatenated).
- a Dict observation space (other than the central-value ``{'obs', 'state'}``) is flattened into
  one vector by the backend; ``observation_space`` is then the flat Box (see ``dict_obs.py``).
- a Tuple-of-Discrete action space takes actions (N, K) int64 like MultiDiscrete; the backend
  converts them to what the env takes.
- pipelined stepping (optional; envpool with ``env_groups`` > 1): ``env_groups`` is a list of row
  slices that partition the N envs; ``send(g, actions)`` (actions for rows ``env_groups[g]``) starts
  group g's step and returns at once, ``recv(g)`` waits for it and returns that group's StepResult
  (same contract, rows of the group only). ``step`` still steps every env. The PPO rollout then
  computes one group's actions while the other group steps (``algos/ppo/ppo.py``).
- ``infos[DROPPED]`` (optional, (N,) bool): rows whose episode the backend cut without an ending (a
  Ray worker died). They come as truncated; episode statistics forget the partial episode instead of
  recording it (see ``rlchain/envs/ray/ray_env.py``). ``log_stats()`` (optional) -> ``{tag: value}``
  counters the trainer writes to TensorBoard every epoch (e.g. ``env/dropped_episodes``).
- exact resume (optional): ``get_state()`` -> anything ``torch.save`` can write (every env's state:
  physics, episode step counters, wrappers' filters, the envs' random generators), or raises
  :class:`StateUnavailable` naming what cannot be read; ``set_state(state)`` puts it back into an env
  built from the same config. Declared by the class (the spec's ``state`` flag); a checkpoint then
  carries it and a resumed run continues the episodes in flight (``rlchain/training/resume.py``).
  Envs without it restart their episodes on resume, and the resume says so in one line.
- ``get_env_state()`` / ``set_env_state(state)`` (optional, rl_games' IVecEnv): a state the env keeps across
  epochs (a curriculum); when ``get_env_state()`` returns something other than None it is stored in every
  checkpoint as ``env_state`` and given back to ``set_env_state`` on resume.

``vecenv_type`` is a registry lookup, as in rl_games: :func:`register` ``(name, creator)`` with
rl_games' creator ``creator(config_name, num_actors, **env_config)``; ``vecenv_type: name`` in a
YAML (or the ``vecenv_type`` of the ``env_configurations`` entry of ``env_name``) selects it. The
creator returns an rl_games IVecEnv (``step`` / ``reset`` / ``get_env_info``, adapted by
:mod:`rlchain.envs.backends.rl_games_vecenv`) or a VecEnv of this contract. The built-in names
(auto, sync, async, native, envpool, RAY, ...) are registered in :mod:`rlchain.builtins`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import gymnasium as gym
import numpy as np

from rlchain.config.errors import ConfigError
from rlchain.registry import ENVS, VECENVS

if TYPE_CHECKING:  # torch is imported where it is used: a Ray env worker of numpy envs never needs it
    import torch

DROPPED = "dropped"


class StateUnavailable(RuntimeError):
    """An env that declares ``get_state`` cannot give its state now (the message says what and why)."""


@dataclass
class StepResult:
    """What one vectorized step returns (see the module docstring for shapes)."""

    obs: Any
    reward: Any
    terminated: Any
    truncated: Any
    final_obs: Any
    infos: dict = field(default_factory=dict)
    game_reward: Any = None
    game_over: Any = None


def dropped_rows(result: StepResult) -> Any:
    """The (N,) bool ``infos[DROPPED]`` mask of a step, or None when the backend sets none."""
    return result.infos.get(DROPPED) if isinstance(result.infos, dict) else None


def close_env(env: Any) -> None:
    """``env.close()`` when the wrapped env has one (a user's env or a PettingZoo one may not)."""
    close = getattr(env, "close", None)
    if callable(close):
        close()


def game_outcome(result: Any, rewards: torch.Tensor, dones: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(game rewards (N,), game ends (N,) bool) of a StepResult, on the device of ``rewards``.

    ``rewards`` / ``dones`` are the training reward and episode end of the step; they are returned
    unchanged unless the env sets ``result.game_reward`` / ``result.game_over``.
    """
    import torch

    if getattr(result, "game_reward", None) is not None:
        rewards = torch.as_tensor(result.game_reward, device=rewards.device).to(rewards.dtype).reshape(-1)
    if getattr(result, "game_over", None) is not None:
        dones = torch.as_tensor(result.game_over, device=dones.device).bool().reshape(-1)
    return rewards, dones


class VecEnv(Protocol):
    """A batch of ``num_envs`` environments stepped together."""

    num_envs: int
    observation_space: gym.Space
    action_space: gym.Space

    def reset(self, seed: int | None = None) -> Any:
        """Reset every env (``seed``: reseed them; None: go on with their streams); returns the
        first observations, (N, *observation_space.shape)."""
        ...

    def step(self, actions: np.ndarray) -> StepResult:
        """Step every env with ``actions`` (N, *action_space.shape); envs whose episode ended are
        reset in the same step (see the module docstring)."""
        ...

    def close(self) -> None:
        """Release the envs (processes, threads, devices)."""
        ...

    def get_state(self) -> Any:  # optional: exact resume (see the module docstring)
        """Every env's state, for :meth:`set_state` of an env built from the same config."""
        ...

    def set_state(self, state: Any) -> None:  # optional, with get_state
        """Put back what :meth:`get_state` returned."""
        ...

    def has_action_mask(self) -> bool:  # optional: absent means False
        """Whether :meth:`get_action_mask` gives masks (with ``use_action_masks: True``)."""
        ...

    def get_action_mask(self) -> Any:  # optional with has_action_mask(): (N, mask_size) bool
        """(N, mask_size) bool, True where an action is allowed in each env's current state."""
        ...


VECENV_KEY = "params.config.vecenv_type"


def register(name: str, creator: Callable[..., Any], overwrite: bool = False) -> None:
    """rl_games' ``vecenv.register``: ``vecenv_type: name`` builds the envs with
    ``creator(config_name, num_actors, **env_config)`` (``config_name`` is ``params.config.env_name``;
    a creator whose signature names ``seed`` or ``render`` also gets them)."""
    VECENVS.register(name, creator, overwrite=overwrite)


def resolve_vecenv_type(vecenv_type: str | None, env_name: str | None = None) -> tuple[str, Callable[..., Any]]:
    """The registered name and creator ``vecenv_type`` selects: the name as registered, else its lower case
    (rl_games' ``RAY`` / ``ENVPOOL``); None -> the ``vecenv_type`` of ``env_name``'s ``env_configurations``
    entry (its ``RAY`` reads as auto: Ray workers are the YAML's choice), else ``auto``. An unknown name is a
    one-line ConfigError with the registered names and a did-you-mean."""
    if vecenv_type is None:
        entry = ENVS.get(env_name) if env_name in ENVS else {}
        vecenv_type = entry.get("vecenv_type")
        if vecenv_type is None or str(vecenv_type).lower() == "ray":
            vecenv_type = "auto"
    name = str(vecenv_type)
    if name not in VECENVS and name.lower() in VECENVS:
        name = name.lower()
    if name not in VECENVS:
        raise ConfigError("", VECENV_KEY, VECENVS.unknown_message(vecenv_type))
    return name, VECENVS.get(name)
