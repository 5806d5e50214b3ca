"""The frozen teacher of ``algo: distill``: an rlchain PPO or SAC checkpoint rebuilt on the distillation's env.

The checkpoint carries its own config (network, model preset, normalizers, the observation group it was
trained on), so the teacher is rebuilt from it, not from the student's YAML. What does not fit is a
one-line :class:`ConfigError` naming the key: a checkpoint of another algorithm or with another action
space (``params.config.teacher_checkpoint``), observation parts other than the ones it was trained on
(``params.config.obs_groups.teacher``).

Dict observations kept per key (a camera student's ``multi_input`` network) give the teacher the keys of
:func:`teacher_keys` (its privileged state): a ``multi_input`` teacher gets them per key, a flat teacher
their values concatenated in that order (:mod:`rlchain.algos.distill.teacher_keys`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import torch

from rlchain.algos.distill.teacher_keys import PATH, TeacherInput, check_encoded, teacher_keys
from rlchain.config.errors import ConfigError
from rlchain.config.obs_groups import ObsGroupsConfig
from rlchain.config.off_policy import SACConfig
from rlchain.config.packaged import resolve_checkpoint
from rlchain.config.params import Params
from rlchain.config.ppo import PPOConfig
from rlchain.config.resolve import params_from_state
from rlchain.envs.factory import takes_dict_obs
from rlchain.envs.obs_dict import is_dict_space
from rlchain.envs.spec import env_spec
from rlchain.envs.vecenv import VecEnv
from rlchain.models.build import PolicyView, model_view, value_size_of
from rlchain.policy.load import load_policy
from rlchain.runs import checkpoint as ckpt

KEY = "params.config.teacher_checkpoint"


@dataclass
class Teacher:
    """The frozen teacher model, the Params it was trained with, its checkpoint's path and ``select``: the
    teacher's input made of the run's observations (the identity but on Dict observations kept per key)."""

    model: Any
    params: Params
    path: str
    select: Callable[[Any], Any] = field(default=lambda obs: obs)


def load_teacher(params: Params, env: VecEnv, device: torch.device) -> Teacher:
    """The teacher of ``params.config.teacher_checkpoint`` on ``env``, frozen (eval mode, no gradients)."""
    cfg, source = params.config, params.source
    path, _ = resolve_checkpoint(cfg.teacher_checkpoint)  # as --checkpoint: a path, nn/<x>.pth or a packaged name
    try:
        state = ckpt.load(path, map_location=device)
    except ckpt.CheckpointError as exc:
        raise ConfigError(source, KEY, str(exc)) from None
    try:
        teacher_params = params_from_state(state["config"]["params"], path)
    except (KeyError, TypeError, ConfigError) as exc:
        raise ConfigError(source, KEY, f"{path}: the checkpoint's config cannot be read back ({exc})") from None
    is_sac = isinstance(teacher_params.config, SACConfig)
    if not (isinstance(teacher_params.config, PPOConfig) or is_sac) or teacher_params.policies is not None:
        raise ConfigError(source, KEY, f"{path} was trained with algo '{teacher_params.algo.name}'; a teacher is a "
                                       f"single-policy PPO checkpoint (a2c_continuous / a2c_discrete) or a SAC one")
    if is_sac and not isinstance(env.action_space, gym.spaces.Box):
        raise ConfigError(source, KEY, f"the SAC teacher in {path} acts in a continuous (Box) action space; this "
                                       f"env's is {env.action_space}")
    space = env.observation_space
    if is_dict_space(space):  # Dict observations kept per key: the teacher reads some of the keys
        return per_key_teacher(params, teacher_params, state, path, env, device)
    if takes_dict_obs(teacher_params):
        raise ConfigError(source, KEY, f"the teacher in {path} reads Dict observations per key (network "
                                       f"multi_input), this run's observations are flat ({space}): give the student "
                                       f"a multi_input network too, so that the env keeps the keys apart")
    groups = cfg.obs_groups or ObsGroupsConfig()
    try:  # the parts the teacher was trained on, on this env
        trained = model_view(teacher_params, space)
    except ConfigError as exc:
        raise ConfigError(source, "params.config.obs_groups.teacher", f"the teacher in {path} was trained on "
                                                                      f"observation parts this env does not have: "
                                                                      f"{exc.message}") from None
    if groups.teacher is None:  # default: what the teacher was trained on
        chosen = trained
        groups = _with_teacher(groups, trained.indices)
    else:
        chosen = model_view(params, space, "teacher", groups)
    if chosen.indices != trained.indices:
        raise ConfigError(source, "params.config.obs_groups.teacher",
                          f"gives {chosen.size} features (indices {_short(chosen.indices)}) but the teacher in "
                          f"{path} was trained on {trained.size} (indices {_short(trained.indices)})")
    try:
        model = load_policy(teacher_params, path, state=state, env=env, device=device, group="teacher",
                            groups=groups).model
    except ckpt.CheckpointError as exc:
        raise ConfigError(source, KEY, f"the teacher does not fit this env's action space {env.action_space} "
                                       f"(or network): {exc}") from None
    except (ConfigError, ValueError) as exc:
        raise ConfigError(source, KEY, f"the teacher in {path} ({teacher_params.model.name}) does not fit this "
                                       f"env's action space {env.action_space}: "
                                       f"{getattr(exc, 'message', exc)}") from None
    return Teacher(frozen(model, is_sac), teacher_params, path)


def per_key_teacher(params: Params, teacher_params: Params, state: dict[str, Any], path: str, env: VecEnv,
                    device: torch.device) -> Teacher:
    """The teacher on Dict observations kept per key: built for the keys it reads (:func:`teacher_keys`), per
    key (multi_input) or flattened, its weights loaded; what does not fit is a one-line ConfigError."""
    source, space = params.source, env.observation_space
    chosen = (params.config.obs_groups or ObsGroupsConfig()).teacher
    own = teacher_params.config
    trained = getattr(getattr(own, "obs_groups", None), getattr(own, "model_group", "teacher"), None)
    keys = teacher_keys(space, chosen, trained, source, path)
    select = TeacherInput(keys, takes_dict_obs(teacher_params))
    if select.per_key:
        check_encoded(state["model"], keys, space, chosen is not None, source, path)
    view = PolicyView(select.space(space), env.action_space, env_spec(env).mask_size, value_size_of(env))
    where = PATH if chosen is not None else KEY
    view_space = view.observation_space
    what = (f"the keys {', '.join(keys)} of this run's observations ({', '.join(space.spaces)})" if select.per_key
            else f"the keys {', '.join(keys)} concatenated ({view_space.shape[0]} features)")
    hint = "" if chosen is not None else f"; name the keys it reads in {PATH}"
    try:
        model = load_policy(teacher_params, path, state=state, env=view, device=device,
                            groups=ObsGroupsConfig()).model
    except ckpt.CheckpointError as exc:
        raise ConfigError(source, where, f"the teacher does not load on {what} with the action space "
                                         f"{env.action_space}: {exc}{hint}") from None
    except (ConfigError, ValueError) as exc:
        raise ConfigError(source, where, f"the teacher in {path} cannot read {what}: "
                                         f"{getattr(exc, 'message', exc)}{hint}") from None
    return Teacher(frozen(model, isinstance(own, SACConfig)), teacher_params, path, select)


def frozen(model: Any, is_sac: bool) -> Any:
    """``model`` without gradients, a SAC one behind :class:`SACTeacher`."""
    for p in model.parameters():
        p.requires_grad_(False)
    return SACTeacher(model) if is_sac else model


class SACTeacher(torch.nn.Module):
    """A frozen SAC policy seen through the distill loop's teacher interface (``evaluate``, ``initial_state``).

    Its label is SAC's deterministic action, as SAC acts: tanh of the actor's mean, rescaled to the env's
    action space (``clip_actions``). :meth:`labels` turns it into the student's distribution parameters: the
    mean the student's ``to_env`` maps onto that same env action, a unit std beside it (mse / huber read
    the mean alone; the std carries nothing, so ``kl`` is refused for a SAC teacher).
    """

    def __init__(self, sac: Any) -> None:
        super().__init__()
        self.sac = sac
        self.dist = sac.dist  # SquashedActions: .dim, .to_env
        self.student_dist: Any = None  # set by :meth:`bind`

    def bind(self, student_dist: Any) -> None:
        """The student's action distribution (DiagGaussian): labels are made in its parameter layout."""
        self.student_dist = student_dist

    def state_dict(self, *args: Any, **kwargs: Any) -> dict[str, Any]:  # the SAC model's keys, as trained
        """The SAC model's weights under its own keys (the checkpoint's ``teacher.model``)."""
        return self.sac.state_dict(*args, **kwargs)

    def initial_state(self, n: int, device: torch.device) -> tuple:
        """SAC's policy is feed-forward: no state."""
        return ()

    def env_action(self, obs: torch.Tensor) -> torch.Tensor:
        """SAC's deterministic action in the env's units: to_env(tanh(mean))."""
        mean, _ = self.sac.network.actor(self.sac.preprocess(obs))
        return self.dist.to_env(torch.tanh(mean))

    def evaluate(self, obs: torch.Tensor, states: Any = None, resets: Any = None, seq_length: int = 1,
                 action_masks: Any = None) -> tuple[torch.Tensor, None, tuple]:
        """(labels in the student's parameter layout (B, 2A), no value, no state)."""
        return self.labels(self.env_action(obs)), None, ()

    def labels(self, env_action: torch.Tensor) -> torch.Tensor:
        """The student's params whose mean maps onto ``env_action`` through the student's ``to_env``."""
        sd = self.student_dist
        mean = env_action.reshape(env_action.shape[0], -1)
        if getattr(sd, "rescale", False):  # to_env: [-1, 1] -> [low, high]; invert it
            low, high = sd._low.to(mean.device), sd._high.to(mean.device)
            mean = (mean - low) / (high - low) * 2.0 - 1.0
        return torch.cat([mean, torch.ones_like(mean)], -1)


def _with_teacher(groups: ObsGroupsConfig, indices: tuple[int, ...]) -> ObsGroupsConfig:
    return dataclasses.replace(groups, teacher=list(indices) if indices else None)


def _short(indices: tuple[int, ...]) -> str:
    shown = ", ".join(str(i) for i in indices[:8])
    return f"[{shown}{', ...' if len(indices) > 8 else ''}]"
