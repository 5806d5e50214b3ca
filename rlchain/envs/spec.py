"""What the trainers, the Player and export need to know about a VecEnv, read once: :class:`EnvSpec`.

The VecEnv contract (:mod:`rlchain.envs.vecenv`) has optional rl_games attributes and methods
(``value_size``, ``num_agents``, ``has_action_mask()``, ``is_tensor_env``, ``env_groups``,
``set_opponent`` ...). :func:`describe` is the one place that probes for them; everything else reads
the frozen spec. The factory attaches it to the env it returns (``env.env_spec``); :func:`env_spec`
gives it for any env (one built elsewhere, e.g. APPO's runner pool or a test's hand-made env, is
described on first use).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from rlchain.errors import EnvError

if TYPE_CHECKING:  # torch is imported where it is used: a Ray env worker of numpy envs never needs it
    import torch

ATTR = "env_spec"
"""The attribute the spec is attached as."""


@dataclass(frozen=True)
class EnvSpec:
    """A VecEnv's shape and optional capabilities (defaults: what an env without the attribute has).

    ``num_envs`` rows = ``num_actors`` envs x ``num_agents`` agents (rl_games multi-agent envs: one
    row per agent). ``mask_size`` is None without action masks. ``tensor_native``: ``step`` takes
    and returns torch tensors on ``device``. ``groups``: the row slices of pipelined stepping
    (``send``/``recv``), None when the env steps all rows together.
    """

    num_envs: int
    observation_space: gym.Space | None  # None for PettingZoo envs (per-agent spaces)
    action_space: gym.Space | None
    num_agents: int = 1
    num_actors: int = 0
    value_size: int = 1
    mask_size: int | None = None
    tensor_native: bool = False
    device: torch.device | None = None
    groups: tuple[slice, ...] | None = None
    central_value: bool = False  # rl_games' use_central_value attribute ({'obs', 'state'} observations)
    pettingzoo: bool = False
    self_play: bool = False  # set_opponent(policy, env_ids)
    scores: bool = False  # pop_scores()
    games_counter: bool = False  # pop_games() (multi-policy play)
    stats: bool = False  # log_stats() -> {tag: value}
    state: bool = False  # get_state() / set_state(state), declared by the env's class (exact resume)

    @property
    def action_masks(self) -> bool:
        """Whether the env gives action masks (``has_action_mask()`` True: ``get_action_mask()``)."""
        return self.mask_size is not None

    def to_env(self, actions: torch.Tensor) -> Any:
        """Actions from a policy in the form ``step`` takes: a tensor on the env's device for a tensor
        env, else a numpy array."""
        if self.tensor_native:
            return actions if self.device is None else actions.to(self.device)
        return actions.cpu().numpy()


def mask_size_of(space: gym.Space | None) -> int:
    """n for Discrete(n), sum(nvec) for MultiDiscrete and Tuple of Discrete; 0 for other spaces."""
    if isinstance(space, gym.spaces.Discrete):
        return int(space.n)
    if isinstance(space, gym.spaces.MultiDiscrete):
        return int(np.sum(space.nvec))
    if isinstance(space, gym.spaces.Tuple) and all(isinstance(s, gym.spaces.Discrete) for s in space.spaces):
        return int(sum(int(s.n) for s in space.spaces))
    return 0


def describe(env: Any) -> EnvSpec:
    """Probe ``env`` once for the optional parts of the VecEnv contract (the only function that does)."""
    num_envs = int(getattr(env, "num_envs", 0))  # 0: a partial env (checks of one capability)
    agents = max(int(getattr(env, "num_agents", 1) or 1), _agents(env))
    has_mask = getattr(env, "has_action_mask", None)
    masks = callable(has_mask) and bool(has_mask())  # get_action_mask() comes with it (vecenv.py)
    tensor = bool(getattr(env, "is_tensor_env", False))
    device = getattr(env, "device", None) if tensor else None
    if device is not None:
        import torch  # a tensor env: torch is imported already

        device = torch.device(device)
    groups = getattr(env, "env_groups", None)
    action_space = getattr(env, "action_space", None)
    return EnvSpec(
        num_envs=num_envs, observation_space=getattr(env, "observation_space", None), action_space=action_space,
        num_agents=agents, num_actors=int(getattr(env, "num_actors", num_envs // agents)),
        value_size=int(getattr(env, "value_size", 1)),
        mask_size=mask_size_of(action_space) if masks else None,
        tensor_native=tensor, device=device,
        groups=None if groups is None else tuple(groups),
        central_value=bool(getattr(env, "use_central_value", False)),
        pettingzoo=bool(getattr(env, "is_pettingzoo", False)),
        self_play=callable(getattr(env, "set_opponent", None)),
        scores=callable(getattr(env, "pop_scores", None)),
        games_counter=callable(getattr(env, "pop_games", None)),
        stats=callable(getattr(env, "log_stats", None)), state=declares_state(env))


def declares_state(env: Any) -> bool:
    """Whether the env's class defines ``get_state`` and ``set_state`` (the class, not the instance: a
    wrapper that forwards unknown attributes to the env it wraps must not lend it the inner env's state)."""
    cls = type(env)
    return callable(getattr(cls, "get_state", None)) and callable(getattr(cls, "set_state", None))


def _agents(env: Any) -> int:
    """rl_games' ``get_number_of_agents()``, 1 without it."""
    fn = getattr(env, "get_number_of_agents", None)
    return int(fn()) if callable(fn) else 1


def attach_spec(env: Any) -> Any:
    """Describe ``env`` and attach the spec as ``env.env_spec`` (when the object takes attributes);
    returns ``env``."""
    _attach(env)
    return env


def env_spec(env: Any) -> EnvSpec:
    """The spec attached to ``env`` (its own attribute, not one a wrapper delegates to the env it
    wraps), else a fresh :func:`describe`, attached when the env allows it."""
    spec = vars(env).get(ATTR) if hasattr(env, "__dict__") else None
    return spec if isinstance(spec, EnvSpec) else _attach(env)


def _attach(env: Any) -> EnvSpec:
    spec = describe(env)
    try:
        setattr(env, ATTR, spec)
    except (AttributeError, TypeError):  # a frozen or slotted object: described again on each env_spec()
        pass
    return spec


def check_obs_shape(obs: Any, num_envs: int, space: Any, where: str) -> None:
    """Observations must be (num_envs, *space.shape); anything else is an EnvError at once. Dict
    observations kept per key (an ObsDict under a Dict space) are checked key by key."""
    if isinstance(obs, dict) and isinstance(space, gym.spaces.Dict):
        missing = [k for k in space.spaces if k not in obs]
        if missing:
            raise EnvError(f"{where}: Dict observations lack the keys {missing} of the observation space")
        for key, sub in space.spaces.items():
            check_obs_shape(obs[key], num_envs, sub, f"{where} ['{key}']")
        return
    shape = tuple(getattr(obs, "shape", ()))
    expected = (num_envs, *space.shape)
    if shape != expected:
        raise EnvError(f"{where}: observations have shape {shape}, expected {expected} "
                       f"(num_envs x observation_space.shape)")
    dtype = str(getattr(obs, "dtype", ""))
    if "float" not in dtype and "uint8" not in dtype and "int" not in dtype:
        raise EnvError(f"{where}: observations have dtype {dtype}, expected a numeric array")
