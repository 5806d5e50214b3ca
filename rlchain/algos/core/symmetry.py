"""Left-right symmetry (rsl_rl's ``symmetry_cfg``): mirror maps of a robot's observation and action, and the
mirror loss that teaches a policy to act as its own mirror image.

A :class:`MirrorMap` mirrors a batch by a permutation and a sign per feature: ``mirrored[:, i] = sign[i] *
x[:, perm[i]]``. The shipped maps are mjlab's velocity tasks' actor group (base linear and angular velocity,
projected gravity, joint positions, joint velocities, last actions, the velocity command) and joint actions,
for the Unitree Go1 (``go1``) and G1 (``g1``): the sagittal plane flips y (linear velocity, gravity, the
commanded vy), the angular velocity's x and z and the commanded yaw rate, swaps left and right joints, and
negates the joints whose axis the mirror reverses (Go1: the hip abduction joints; G1: every roll and yaw joint).
A user's map is ``module:function``, called with the observation and action sizes.

Data augmentation (:func:`augmented_storage`, rsl_rl's ``use_data_augmentation``) trains the PPO objective on a
rollout doubled by its mirror images, with the originals' advantages, returns and old log-probabilities. The
mirror loss (:class:`MirrorLoss`) is the mean squared difference between the policy's mean action on a
mirrored observation and the mirror of its mean action on the observation (the latter held fixed), weighted by
``mirror_loss_coef`` and minimised over the rollout after each PPO update.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import torch

from rlchain.algos.core.optimizer_step import optimizer_step
from rlchain.registry import import_object

GO1_JOINTS = tuple(f"{leg}_{part}_joint" for leg in ("FR", "FL", "RR", "RL") for part in ("hip", "thigh", "calf"))
"""mjlab's Go1 joint (and action) order."""
G1_JOINTS = tuple(
    [f"left_{j}_joint" for j in ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll")]
    + [f"right_{j}_joint" for j in ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll")]
    + ["waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint"]
    + [f"left_{j}_joint" for j in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll",
                                    "wrist_pitch", "wrist_yaw")]
    + [f"right_{j}_joint" for j in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll",
                                     "wrist_pitch", "wrist_yaw")])
"""mjlab's G1 joint (and action) order (29 joints)."""

# (feature sign under the mirror) of the 3-vectors in the velocity tasks' actor group
LINEAR = (1.0, -1.0, 1.0)  # a polar vector in the body frame: y flips
ANGULAR = (-1.0, 1.0, -1.0)  # an axial vector: x and z flip
COMMAND = (1.0, -1.0, -1.0)  # (vx, vy, yaw rate)


@dataclass(frozen=True)
class MirrorMap:
    """``mirrored[:, i] = sign[i] * x[:, perm[i]]`` for the observation and for the action."""

    obs_perm: tuple[int, ...]
    obs_sign: tuple[float, ...]
    act_perm: tuple[int, ...]
    act_sign: tuple[float, ...]

    def __post_init__(self) -> None:
        for perm, sign, what in ((self.obs_perm, self.obs_sign, "observation"),
                                 (self.act_perm, self.act_sign, "action")):
            if sorted(perm) != list(range(len(perm))) or len(sign) != len(perm):
                raise ValueError(f"a mirror map's {what} permutation must hold 0..{len(sign) - 1} once each, "
                                 f"with one sign per entry")

    def mirror_obs(self, obs: torch.Tensor) -> torch.Tensor:
        """(B, obs) -> the mirrored observations."""
        return _apply(obs, self.obs_perm, self.obs_sign)

    def mirror_actions(self, actions: torch.Tensor) -> torch.Tensor:
        """(B, actions) -> the mirrored actions."""
        return _apply(actions, self.act_perm, self.act_sign)


def _apply(x: torch.Tensor, perm: Sequence[int], sign: Sequence[float]) -> torch.Tensor:
    index = torch.tensor(perm, device=x.device)
    return x.index_select(-1, index) * torch.tensor(sign, dtype=x.dtype, device=x.device)


def joint_mirror(joints: Sequence[str], pairs: Sequence[tuple[str, str]], negated: Callable[[str], bool]
                 ) -> tuple[list[int], list[float]]:
    """Permutation and signs of a joint vector: joint i takes the value of its mirror joint (``pairs`` of name
    prefixes swapped), negated where ``negated(name)``."""
    where = {name: i for i, name in enumerate(joints)}
    perm, sign = [], []
    for name in joints:
        other = name
        for a, b in pairs:
            if name.startswith(a):
                other = b + name[len(a):]
            elif name.startswith(b):
                other = a + name[len(b):]
        perm.append(where[other])
        sign.append(-1.0 if negated(name) else 1.0)
    return perm, sign


def velocity_task_map(joints: Sequence[str], pairs: Sequence[tuple[str, str]], negated: Callable[[str], bool],
                      obs_size: int, action_size: int, robot: str) -> MirrorMap:
    """The map of mjlab's velocity tasks' actor group: lin vel, ang vel, gravity, joint pos, joint vel, last
    actions, command (3 + 3 + 3 + 3 x joints + 3)."""
    n = len(joints)
    expected = 12 + 3 * n
    if obs_size != expected or action_size != n:
        raise ValueError(f"the {robot} mirror map is for mjlab's velocity tasks: an actor observation of {expected} "
                         f"and {n} actions; this env has {obs_size} and {action_size}")
    jperm, jsign = joint_mirror(joints, pairs, negated)
    perm: list[int] = [0, 1, 2, 3, 4, 5, 6, 7, 8]
    sign: list[float] = [*LINEAR, *ANGULAR, *LINEAR]
    for block in range(3):  # joint positions, joint velocities, last actions
        start = 9 + block * n
        perm += [start + p for p in jperm]
        sign += jsign
    perm += [9 + 3 * n, 10 + 3 * n, 11 + 3 * n]
    sign += list(COMMAND)
    return MirrorMap(tuple(perm), tuple(sign), tuple(jperm), tuple(jsign))


def go1(obs_size: int, action_size: int) -> MirrorMap:
    """Unitree Go1 in mjlab's velocity tasks: front/rear right legs swap with the left ones, hips negate."""
    return velocity_task_map(GO1_JOINTS, (("FR_", "FL_"), ("RR_", "RL_")), lambda name: "_hip_" in name,
                             obs_size, action_size, "go1")


def g1(obs_size: int, action_size: int) -> MirrorMap:
    """Unitree G1 (29 joints) in mjlab's velocity tasks: left and right swap, roll and yaw joints negate."""
    return velocity_task_map(G1_JOINTS, (("left_", "right_"),), lambda name: "roll" in name or "yaw" in name,
                             obs_size, action_size, "g1")


SHIPPED = {"go1": go1, "g1": g1}


def resolve_mirror(name: str, obs_size: int, action_size: int) -> MirrorMap:
    """``symmetry.mirror``: a shipped map's name or ``module:function``; ValueError (one line) when it is not."""
    if name in SHIPPED:
        return SHIPPED[name](obs_size, action_size)
    if ":" not in name:
        raise ValueError(f"'{name}' is neither a shipped mirror map ({', '.join(SHIPPED)}) nor module:function")
    try:
        function = import_object(name)
    except ValueError as exc:
        raise ValueError(f"cannot load the mirror map {name}: {exc}") from None
    built = function(obs_size, action_size)
    if not isinstance(built, MirrorMap):
        raise ValueError(f"{name} returned a {type(built).__name__}, expected a rlchain MirrorMap")
    return built


class MirrorLoss:
    """``mirror_loss_coef`` x MSE(mean action on the mirrored observation, the mirror of the mean action), with
    its own Adam optimizer over the actor-critic's parameters (lr: the PPO learning rate)."""

    def __init__(self, model: Any, mirror: MirrorMap, coef: float, learning_rate: float) -> None:
        self.model, self.mirror, self.coef = model, mirror, float(coef)
        self.optimizer = torch.optim.Adam([p for p in model.parameters() if p.requires_grad], lr=learning_rate)

    def loss(self, obs: torch.Tensor) -> torch.Tensor:
        """The weighted mirror loss of the flat observations ``obs`` (the model's own view is mirrored)."""
        model = self.model
        view = model.view(obs)
        with torch.no_grad():
            target = self.mirror.mirror_actions(model.dist.mode(_params(model, obs)))
        mirrored = mirrored_obs(obs, view, self.mirror.mirror_obs(view), model.obs_slice)
        return self.coef * torch.nn.functional.mse_loss(model.dist.mode(_params(model, mirrored)), target)

    def train_on(self, obs: torch.Tensor, minibatch_size: int) -> float:
        """One shuffled pass over the rows of ``obs``; the mean loss."""
        order = torch.randperm(obs.shape[0], device=obs.device)
        losses = []
        for start in range(0, obs.shape[0], minibatch_size):
            loss = self.loss(obs[order[start:start + minibatch_size]])
            optimizer_step(self.optimizer, loss)
            losses.append(float(loss.detach()))
        return sum(losses) / max(len(losses), 1)


def _params(model: Any, obs: torch.Tensor) -> torch.Tensor:
    params, _, _ = model.evaluate(obs)
    return params


def mirrored_obs(obs: torch.Tensor, view: torch.Tensor, mirrored_view: torch.Tensor, obs_slice: Any) -> torch.Tensor:
    """The flat observations with the model's view replaced by its mirror (a critic part stays as it is)."""
    if obs_slice is None:
        return mirrored_view
    out = obs.clone()
    if isinstance(obs_slice, slice):
        out[:, obs_slice] = mirrored_view
    else:
        out[:, torch.tensor(obs_slice, device=obs.device)] = mirrored_view
    return out


MIRRORED_FIELDS = ("log_probs", "values", "final_values", "rewards", "terminated", "dones", "advantages", "returns")
"""Rollout fields a mirrored sample shares with its original (rsl_rl's data augmentation keeps the old
log-probabilities, values, returns and advantages)."""


def mirrored_params(params: torch.Tensor, mirror: MirrorMap) -> torch.Tensor:
    """A Gaussian policy's (B, 2 x actions) parameters [mean | scale] under the mirror: the mean mirrored, the
    scale only permuted (a scale has no sign)."""
    n = len(mirror.act_perm)
    mean, scale = params[:, :n], params[:, n:]
    return torch.cat([mirror.mirror_actions(mean), scale.index_select(1, torch.tensor(mirror.act_perm,
                                                                                      device=params.device))], 1)


def augmented_storage(storage: Any, mirror: MirrorMap, obs_slice: Any) -> Any:
    """A (T, 2N) copy of a filled (T, N) rollout: the N envs as they were, then their mirror images (the
    model's observation view and the actions mirrored, the distribution parameters too, the rest shared)."""
    t, n = storage.horizon, storage.num_envs
    out = copy.copy(storage)
    out.num_envs = 2 * n
    obs = storage.obs.reshape(t * n, -1)
    view = obs if obs_slice is None else (obs[:, obs_slice] if isinstance(obs_slice, slice)
                                          else obs[:, torch.tensor(obs_slice, device=obs.device)])
    mirrored = mirrored_obs(obs, view, mirror.mirror_obs(view), obs_slice).reshape(storage.obs.shape)
    out.obs = torch.cat([storage.obs, mirrored], 1)
    actions = storage.actions.reshape(t * n, -1)
    out.actions = torch.cat([storage.actions, mirror.mirror_actions(actions).reshape(storage.actions.shape)], 1)
    params = storage.params.reshape(t * n, -1)
    out.params = torch.cat([storage.params, mirrored_params(params, mirror).reshape(storage.params.shape)], 1)
    for name in MIRRORED_FIELDS:
        value = getattr(storage, name)
        setattr(out, name, torch.cat([value, value], 1))
    out.action_masks, out.states, out.resets = None, (), None
    return out
