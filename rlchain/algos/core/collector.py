"""The on-policy collector: step the envs for ``horizon_length`` steps, the one env loop of on-policy learning.

Every on-policy algorithm steps its envs here: PPO and GRPO, a user's algorithm (the REINFORCE example),
APPO's runners (their fragments), multi-policy PPO, distillation's student rollouts, the value warm start of
a distilled PPO student and APG's differentiable segments. The loop is the same for all: check the stop
signal, act on the observations (under the env's action masks), step the envs, report the step's outcome to
the run, carry the observations and the RNN states (zeroed where an episode ended) to the next step.

By default it acts with the model and fills a RolloutStorage: observations, actions, log-probs, values,
distribution parameters, action masks, RNN states and their episode starts, rewards (shaped), terminations
and dones, and on a time-out the value to bootstrap from (``value_bootstrap``); the env's step outcome
(episode statistics, success, callbacks) goes to the run through :meth:`RunContext.record_step`. With a
central value the values and the bootstrap come from it, and its RNN states ride along after the model's.
An algorithm that acts or records otherwise gives the collector hooks (:class:`OnPolicyCollector`'s keyword
arguments): its own act step, the env's action format, how a step's outcome is recorded, how observations
are read, and a per-step hook that sees each :class:`CollectedStep`; without a storage nothing is stored,
and ``differentiable`` keeps the model's mode and every tensor's graph (APG backpropagates through the
env's dynamics).

Two ways, the same transitions: synchronous (act for all envs, step all, observe all), or pipelined over
env groups (``env.env_groups`` with ``send``/``recv``, envpool with ``env_groups`` > 1), where one group's
env step runs in the background while the collector takes the other group's result and computes its
actions. :meth:`OnPolicyCollector._act` and :meth:`OnPolicyCollector._observe` work on a slice of env
rows, so both ways share them (the pipelined way with the default act step and recording only).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol

import numpy as np
import torch

from rlchain.algos.core.returns import shape_with
from rlchain.algos.core.storage import ALL
from rlchain.envs.spec import check_obs_shape
from rlchain.envs.vecenv import VecEnv, dropped_rows
from rlchain.networks.rnn import zero_finished


class StepOutcome(NamedTuple):
    """An env step's outcome as tensors on the training device, each (N,) (rewards (N,) or (N, value_size)):
    what :meth:`RunContext.record_step` returns once the step is in the run's statistics."""

    rewards: torch.Tensor
    terminated: torch.Tensor
    truncated: torch.Tensor
    dones: torch.Tensor
    """terminated | truncated"""


class ActFn(Protocol):
    """An act step: ``(t, obs, states, masks) -> out``, ``out["actions"]`` in the model's format and, for an
    RNN, ``out["states"]`` the states after the step (all the collector carries); anything else in ``out``
    reaches the per-step hook. ``states`` is the tuple the collector carries (empty without an RNN)."""

    def __call__(self, t: int, obs: Any, states: tuple, masks: torch.Tensor | None) -> dict[str, Any]: ...


@dataclass
class CollectedStep:
    """One env step as the collector took it, for an algorithm's per-step hook (``on_step``)."""

    t: int
    """The step's index in the rollout."""
    rows: slice
    """The env rows the step is for (all of them but in a pipelined rollout)."""
    obs: Any
    """The observations acted on."""
    masks: torch.Tensor | None
    """The action masks acted under (None without)."""
    out: dict[str, Any]
    """What the act step returned."""
    result: Any
    """The env's StepResult."""
    outcome: StepOutcome | None
    """The step's (rewards, terminated, truncated, dones) as recorded (None when the recording returns none)."""
    next_obs: Any
    """The observations after the step, as the collector carries them."""


class PipelineChoice(Protocol):
    """Over env groups: pipeline them or step them together (PPO's ``env_groups: auto`` measures which,
    rlchain.algos.ppo.env_layout.PipelineChoice)."""

    def pipelined(self) -> bool: ...

    def record(self, pipelined: bool, seconds: float) -> None: ...


class AlwaysPipelined:
    """Env groups are always pipelined (an explicit ``env_groups``)."""

    def pipelined(self) -> bool:
        return True

    def record(self, pipelined: bool, seconds: float) -> None:
        return None


def as_is(x: Any) -> Any:
    """A ``to_env`` / ``read_obs`` hook for callers whose actions and observations pass between their policies and
    the env unchanged (per-agent dicts of the multi-policy algorithms; APG's tensors with their graph)."""
    return x


def no_record(result: Any, rows: slice) -> None:
    """A ``record`` hook for callers whose policies record their agents' outcomes themselves (nothing run-wide)."""
    return None


class OnPolicyCollector:
    """Collects rollouts of ``model`` on ``env`` for the run ``ctx`` (its RunContext), into ``storage`` when
    one is given.

    ``cfg`` (the run's config) gives ``horizon_length`` (``horizon`` overrides it), and with a storage
    ``reward_shaper``, ``gamma`` and where it has them (PPO's keys) ``value_bootstrap`` (default False),
    ``timeout_bootstrap`` and ``zero_rnn_on_done``; ``central_value`` (optional) gives the values and adds
    its RNN states after the model's; ``use_masks`` asks the env for action masks every step. Between
    rollouts it holds where the envs stand: :attr:`obs` (the next observations, set by the algorithm's
    ``start``), :attr:`rnn_states` and :attr:`resets` (their episode starts); after a rollout with a storage
    :attr:`last_values` holds the values of the next observations (raw scale), for the returns.

    The hooks (each optional; the default in brackets): ``act`` (:class:`ActFn`) [the model's act step,
    with the central value's values and states], ``to_env`` (model-format actions -> what ``env.step``
    takes) [``ctx.spec.to_env(model.dist.to_env(actions))``], ``record`` (``(result, rows) -> StepOutcome``
    or None) [``ctx.record_step``], ``read_obs`` (the env's observations -> what the next step acts on)
    [``ctx.to_tensor``], ``on_step`` (called with every :class:`CollectedStep` once the step is recorded),
    ``differentiable`` [False: the model acts in eval mode; True: its mode is left as it is and nothing is
    detached, for a loss backpropagated through the rollout]. PPO's extras: ``graphed_act`` (the act step
    as a CUDA graph), ``reward_bonus`` (an intrinsic reward of each step's next observations),
    ``fold_obs_each_step`` (the input statistics fold each step in), ``carries_states`` (start from zero RNN
    states; else the owner sets them with :meth:`place`). An owner moves the envs' position with
    :meth:`place` and :meth:`reset_states`.
    """

    def __init__(self, env: VecEnv, model: Any, ctx: Any, cfg: Any, *, storage: Any = None, central_value: Any = None,
                 use_masks: bool = False, pipeline_choice: PipelineChoice | None = None, horizon: int | None = None,
                 act: ActFn | None = None, to_env: Callable[[Any], Any] | None = None,
                 record: Callable[[Any, slice], StepOutcome | None] | None = None,
                 read_obs: Callable[[Any], Any] | None = None, on_step: Callable[[CollectedStep], None] | None = None,
                 differentiable: bool = False, graphed_act: Any = None,
                 reward_bonus: Callable[[Any], torch.Tensor] | None = None, fold_obs_each_step: bool = False,
                 carries_states: bool = False) -> None:
        self.env, self.model, self.ctx, self.cfg = env, model, ctx, cfg
        self.storage, self.central_value, self.use_masks = storage, central_value, use_masks
        self.pipeline_choice: PipelineChoice = pipeline_choice or AlwaysPipelined()
        self.horizon = horizon
        self.act: ActFn = act or self.policy_act
        self.to_env = to_env or self.env_format
        self.record = record or ctx.record_step
        self.read_obs = read_obs or ctx.to_tensor
        self.on_step = on_step
        self.differentiable = differentiable
        self.graphed_act = graphed_act
        """``cuda_graph``: the act step captured as a CUDA graph (rlchain.algos.ppo.graph_step.GraphedAct)."""
        self.reward_bonus = reward_bonus
        """Optional: (next observations of a step's rows) -> (rows, 1) rewards added to the shaped env reward
        (PPO's ``rnd``)."""
        self.fold_obs_each_step = fold_obs_each_step
        """Fold each step's next observations into the model's (and central value's) input statistics as they
        come (``obs_normalizer_update: step``, rsl_rl's timing)."""
        self.num_envs, self.device = env.num_envs, ctx.device
        self.obs: Any = None
        # carries_states: start from the model's (and central value's) zero RNN states; else () until set
        self.carries_states = carries_states
        self.rnn_states: tuple[torch.Tensor, ...] = self.initial_states() if carries_states else ()
        self.resets = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        self.last_values: torch.Tensor | None = None

    def initial_states(self) -> tuple[torch.Tensor, ...]:
        """Zero RNN states for every env: the model's, then the central value's."""
        states = tuple(self.model.initial_state(self.num_envs, self.device))
        if self.central_value is not None:
            states += self.central_value.initial_state(self.num_envs, self.device)
        return states

    def place(self, obs: Any, rnn_states: tuple[torch.Tensor, ...] | None = None,
              resets: torch.Tensor | None = None) -> None:
        """Where the envs stand before the next rollout: their observations (after a reset or a restore), and
        when given the RNN states and their episode-start flags (a restored position)."""
        self.obs = obs
        if rnn_states is not None:
            self.rnn_states = rnn_states
        if resets is not None:
            self.resets = resets

    def reset_states(self) -> None:
        """Fresh episodes everywhere: zero RNN states, every row starts an episode."""
        self.rnn_states = self.initial_states()
        self.resets.fill_(True)

    def policy_act(self, t: int, obs: torch.Tensor, states: tuple, masks: torch.Tensor | None) -> dict[str, Any]:
        """The default act step: the model's, with the central value's values and RNN states when there is one."""
        model = self.model
        out = model.act(obs, states=states, action_masks=masks)
        if self.central_value is None:
            return out
        values, cv_states = self.central_value.step(obs, states[model.num_states:])
        return {**out, "values": values, "states": tuple(out["states"] or ()) + cv_states}

    def env_format(self, actions: torch.Tensor) -> Any:
        """The default env format of model-format ``actions``: the distribution's, on the env's side."""
        return self.ctx.spec.to_env(self.model.dist.to_env(actions))

    def _action_masks(self) -> torch.Tensor | None:
        """(N, mask_size) bool masks of valid actions from the env, when use_action_masks is on."""
        if not self.use_masks:
            return None
        return self.ctx.to_tensor(self.env.get_action_mask()).bool()

    def rollout(self) -> bool:
        """Step the envs for the horizon, filling the storage; False if a stop signal came. Over env groups
        (with the default act step and recording), pipelined or stepped together as :attr:`pipeline_choice`
        says (the same transitions)."""
        if not self.differentiable:
            self.model.eval()
        groups = self.ctx.spec.groups
        if groups is None or len(groups) < 2 or not self._pipelines():
            return self._rollout()
        pipelined = self.pipeline_choice.pipelined()
        start = time.perf_counter()
        complete = self._pipelined_rollout(groups) if pipelined else self._rollout()
        if complete:
            self.pipeline_choice.record(pipelined, time.perf_counter() - start)
        return complete

    def _pipelines(self) -> bool:
        """Whether the hooks work on env groups: the default act step and recording, no per-step hook."""
        return self.act == self.policy_act and self.on_step is None and self.storage is not None

    @property
    def horizon_length(self) -> int:
        """Steps per rollout: ``horizon`` when given, else the config's ``horizon_length``."""
        return self.horizon if self.horizon is not None else self.cfg.horizon_length

    def _rollout(self) -> bool:
        """The synchronous rollout: act for every env, step them all, observe them all."""
        for t in range(self.horizon_length):
            if self.ctx.stop_requested():
                return False
            pending, actions = self._act(t, ALL)
            result = self.env.step(actions)
            if self.storage is not None and self.ctx.epoch == 0 and t == 0:
                check_obs_shape(result.obs, self.num_envs, self.env.observation_space, "env step")
            self._observe(t, ALL, result, *pending)
        if self.storage is not None:
            self.last_values = self._value(self.obs, self.rnn_states)
        return True

    def _pipelined_rollout(self, groups: list[slice]) -> bool:
        """The rollout over env groups that step in the background (``env.send`` / ``env.recv``).

        Group g's actions for step t go out as soon as they are computed; while envpool's threads
        step it, the collector takes the other group's result and computes that group's actions. Each
        row sees exactly the sequence of the synchronous rollout: obs -> act -> env answer -> next obs.
        """
        self.obs, self.resets = self.obs.clone(), self.resets.clone()  # filled in place, group by group
        self.rnn_states = tuple(s.clone() for s in self.rnn_states)
        pending: list[tuple | None] = [None] * len(groups)

        def drain(t: int) -> None:
            for g, rows in enumerate(groups):
                if pending[g] is not None:
                    self._observe(t, rows, self.env.recv(g), *pending[g])
                    pending[g] = None

        for t in range(self.horizon_length):
            if self.ctx.stop_requested():
                drain(t - 1)
                return False
            for g, rows in enumerate(groups):
                if pending[g] is not None:
                    self._observe(t - 1, rows, self.env.recv(g), *pending[g])
                pending[g], actions = self._act(t, rows)
                self.env.send(g, actions)
        drain(self.horizon_length - 1)
        self.last_values = self._value(self.obs, self.rnn_states)
        return True

    def _act(self, t: int, rows: slice) -> tuple[tuple, Any]:
        """Policy step t for the envs ``rows``: with a storage, record obs, actions, values and states in it.

        Returns ((obs, masks, the act step's output, next RNN states) for :meth:`_observe`, the actions in
        the env's format).
        """
        obs, states, resets = self.obs, self.rnn_states, self.resets
        if rows is not ALL:
            obs, resets, states = obs[rows], resets[rows], tuple(s[:, rows] for s in states)
        masks = self._action_masks()
        if self.graphed_act is not None and rows is ALL:  # cuda_graph: feed-forward, no masks, every env
            out = self.graphed_act(obs)
        else:
            out = self.act(t, obs, states, masks)
        next_states = tuple(out.get("states") or ())
        if self.storage is not None:
            self.storage.add(t, obs, out["actions"], out["log_probs"], out["values"], out["params"], masks,
                             states, resets, rows=rows)
        return (obs, masks, out, next_states), self.to_env(out["actions"])

    def _observe(self, t: int, rows: slice, result: Any, obs: Any, masks: torch.Tensor | None, out: dict,
                 next_states: tuple) -> None:
        """The env's answer to step t for the envs ``rows``: its outcome recorded (with a storage: rewards,
        dones and bootstrap values into it), the per-step hook, then the next obs and RNN states."""
        outcome = self.record(result, rows)
        if self.storage is not None:
            self._store_outcome(t, rows, result, outcome, out["values"], next_states)
        next_obs = self.read_obs(result.obs)
        if self.fold_obs_each_step:  # obs_normalizer_update step: rsl_rl's timing
            with torch.no_grad():
                self.model.update_normalizers(obs=next_obs)
                if self.central_value is not None:
                    self.central_value.update_normalizers(obs=next_obs)
        if self.on_step is not None:
            self.on_step(CollectedStep(t, rows, obs, masks, out, result, outcome, next_obs))
        if next_states:
            dones = outcome[3]
            if getattr(self.cfg, "zero_rnn_on_done", True):
                next_states = zero_finished(next_states, dones)
        if rows is ALL:
            self.obs = next_obs
            if next_states:
                self.rnn_states, self.resets = next_states, dones
            return
        self.obs[rows] = next_obs
        if next_states:
            for state, new in zip(self.rnn_states, next_states):
                state[:, rows] = new
            self.resets[rows] = dones

    def _store_outcome(self, t: int, rows: slice, result: Any, outcome: StepOutcome, values: torch.Tensor,
                       next_states: tuple) -> None:
        """Rewards (shaped, plus :attr:`reward_bonus`), terminations, dones and the time-outs' bootstrap
        values of step t into the storage."""
        cfg, storage = self.cfg, self.storage
        bootstrap = getattr(cfg, "value_bootstrap", False)  # PPO's keys; another algorithm's config may lack them
        rewards, terminated, truncated, dones = outcome
        if rewards.dim() == 1:
            rewards = rewards.unsqueeze(-1)
        rs = cfg.reward_shaper
        if rs.identity:  # skipped: its two ops cost a small rollout's step a few percent
            shaped = rewards
        else:
            shaped = shape_with(rewards, rs)
        if self.reward_bonus is not None:  # e.g. PPO's rnd: an intrinsic reward of the next observation (rsl_rl)
            shaped = shaped + self.reward_bonus(result.obs)
        dropped = dropped_rows(result)
        if dropped is not None and bool(np.any(dropped)):  # a dead Ray worker's envs: zero advantage
            if shaped is rewards:  # the step's outcome stays as the env gave it
                shaped = shaped.clone()
            lost = self.ctx.to_tensor(np.asarray(dropped)).bool()
            shaped[lost] = values[lost] * ((1 - cfg.gamma) if bootstrap else 1.0)
        # RLlib's advantage standardization (advantage_normalization rllib) reads V(final obs) at terminations too
        every_end = getattr(cfg, "advantage_normalization", None) == "rllib"
        if bootstrap and bool((dones if every_end else truncated).any()):
            idx = (dones if every_end else truncated & ~terminated).nonzero().squeeze(-1)
            previous = getattr(cfg, "timeout_bootstrap", "final_obs") == "previous_value"
            if idx.numel() and previous:  # rl_games: V(s_t), no extra pass
                storage.final_values[t, rows][idx] = values[idx]
            elif idx.numel():
                final_obs = self.ctx.to_tensor(result.final_obs)[idx]
                row_states = tuple(s[:, idx] for s in next_states)
                storage.final_values[t, rows][idx] = self._value(final_obs, row_states)
        storage.add_outcome(t, shaped, terminated if bootstrap else dones, dones, rows=rows)

    def _value(self, obs: torch.Tensor, states: tuple) -> torch.Tensor:
        """Raw-scale values of ``obs``: the central value's when there is one, else the model's."""
        if self.central_value is not None:
            return self.central_value.value(obs, states[self.model.num_states:])
        return self.model.value(obs, states)
