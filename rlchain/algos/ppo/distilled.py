"""Stage three of teacher-to-student (docs/distillation.md): PPO starts from a distilled student.

``config.distilled_checkpoint`` names an ``algo: distill`` checkpoint; its student's weights are loaded into
PPO's model (which reads ``obs_groups.student``, the view the student was distilled on). The value head
is either kept as the student has it (``distilled_value: scratch``; distillation does not train it) or
first regressed on the frozen teacher's values (``teacher``) over ``distilled_value_epochs`` rollouts of
the student acting, the teacher rebuilt from the copy the distilled checkpoint holds. Only the value head
moves during that regression, so the policy PPO starts from is exactly the distilled one.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import torch

from rlchain.algos.core.collector import CollectedStep, OnPolicyCollector
from rlchain.algos.core.optimizer_step import optimizer_step
from rlchain.config.errors import ConfigError
from rlchain.config.obs_groups import ObsGroupsConfig
from rlchain.config.params import Params
from rlchain.config.resolve import params_from_state
from rlchain.envs.vecenv import VecEnv
from rlchain.models.build import model_view
from rlchain.policy.load import load_policy
from rlchain.runs import checkpoint as ckpt

KEY = "params.config.distilled_checkpoint"


def load_distilled(params: Params, env: VecEnv, model: Any, device: torch.device) -> Any:
    """Load the distilled student into ``model``; returns the frozen teacher (a model) when
    ``distilled_value`` is ``teacher``, else None. One-line ConfigErrors naming the key."""
    cfg, source = params.config, params.source
    path = cfg.distilled_checkpoint
    try:
        state = ckpt.load(path, map_location=device)
    except ckpt.CheckpointError as exc:
        raise ConfigError(source, KEY, str(exc)) from None
    if state.get("algo") != "distill" or "teacher" not in state:
        raise ConfigError(source, KEY, f"{path} was written by algo '{state.get('algo')}', not by distill")
    student_params = params_from_state(state["config"]["params"], path)
    groups = student_params.config.obs_groups or ObsGroupsConfig()
    space = env.observation_space
    theirs = model_view(student_params, space, "student", groups).indices
    ours = model_view(params, space).indices
    if theirs != ours:
        raise ConfigError(source, "params.config.obs_groups.student",
                          f"PPO's model reads {len(ours)} features but the student in {path} was distilled on "
                          f"{len(theirs)} (set obs_groups.student as the distill config has it and "
                          f"obs_groups.policy: student)")
    try:
        ckpt.load_model_state(model, state, path)
    except ckpt.CheckpointError as exc:
        raise ConfigError(source, KEY, f"the student does not fit PPO's network: {exc} (params.network, "
                                       f"normalize_input and normalize_value must be the distill config's)") from None
    if cfg.distilled_value != "teacher":
        return None
    teacher_state = state["teacher"]
    teacher_params = params_from_state(teacher_state["config"]["params"], path)
    if teacher_params.algo.name == "sac":
        raise ConfigError(source, "params.config.distilled_value", f"teacher regresses on a PPO teacher's state "
                                                                   f"values; the student in {path} was distilled "
                                                                   f"from a SAC teacher (no state value): use scratch")
    trained = model_view(teacher_params, space).indices  # the view the teacher was trained on
    teacher_groups = dataclasses.replace(groups, teacher=list(trained) if trained else None)
    teacher = load_policy(teacher_params, path, device=device, env=env, state=teacher_state, group="teacher",
                          groups=teacher_groups).model  # in eval mode
    for p in teacher.parameters():
        p.requires_grad_(False)
    return teacher


def value_head(model: Any) -> list[torch.nn.Parameter]:
    """The parameters of the model's value head (the network's ``value`` layer)."""
    head = getattr(model.a2c_network, "value", None)
    if not isinstance(head, torch.nn.Module):
        raise ConfigError("", "params.config.distilled_value", "teacher needs a network with a `value` layer "
                                                             "(the actor_critic builder's); use scratch")
    return list(head.parameters())


def warm_start_value(trainer: Any, teacher: Any, epochs: int, lr: float = 1e-3, steps: int = 25) -> float:
    """Regress ``trainer.model``'s value head on ``teacher``'s values over ``epochs`` rollouts of the student
    acting (its own sampling, as PPO will; the on-policy collector steps the envs), ``steps`` Adam steps on
    each; returns the last rollout's mean squared error (normalized scale).
    The frames are not counted and the episodes not recorded: they happen before training starts."""
    model, ctx, cfg = trainer.model, trainer.ctx, trainer.cfg
    params = value_head(model)
    opt = torch.optim.Adam(params, lr=lr)
    n = trainer.num_envs
    own = len(model.initial_state(n, trainer.device))  # the student's RNN states, then the teacher's
    rows: list[torch.Tensor] = []
    targets: list[torch.Tensor] = []
    starts: list[torch.Tensor] = []
    resets = [torch.ones(n, dtype=torch.bool, device=trainer.device)]

    def act(t: int, obs: torch.Tensor, states: tuple, masks: torch.Tensor | None) -> dict[str, Any]:
        s_states, t_states = states[:own], states[own:]
        with torch.no_grad():
            out = model.act(obs, states=s_states or None)
            t_value = teacher.value(obs, t_states or None)
            _, _, t_next = teacher.evaluate(obs, t_states or None)
        rows.append(obs)
        targets.append(t_value)
        starts.append(resets[0])
        return {"actions": out["actions"], "states": tuple(out["states"] or ()) + tuple(t_next or ())}

    def on_step(step: CollectedStep) -> None:
        resets[0] = step.outcome[3]

    collector = OnPolicyCollector(trainer.env, model, ctx, cfg, act=act, record=ctx.step_outcome, on_step=on_step)
    collector.place(trainer.collector.obs, (tuple(model.initial_state(n, trainer.device))
                                            + tuple(teacher.initial_state(n, trainer.device))))
    loss = torch.zeros(())
    for _ in range(epochs):
        rows.clear(), targets.clear(), starts.clear()
        first = tuple(s.clone() for s in collector.rnn_states[:own])
        if not collector.rollout():  # a stop signal: training stops before its first epoch
            break
        horizon = len(rows)

        def seq(x: list[torch.Tensor]) -> torch.Tensor:  # (T, N, ...) -> env by env rows
            return torch.stack(x).transpose(0, 1).flatten(0, 1)

        model.train()
        batch, starts_rows, target = seq(rows), seq(starts), model.norm_value(seq(targets))
        for _ in range(steps):
            _, value, _ = model.evaluate(batch, first or None, starts_rows, seq_length=horizon)
            loss = (value - target).square().mean()
            optimizer_step(opt, loss)
        model.eval()
    trainer.collector.reset_states()
    trainer.collector.place(ctx.reset_envs())  # fresh episodes: the statistics start with training
    return float(loss.detach())
