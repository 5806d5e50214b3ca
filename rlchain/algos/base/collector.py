"""The on-policy collector: step the envs for ``horizon_length`` steps and fill a RolloutStorage.

What it records per step: observations, actions, log-probs, values, distribution parameters, action masks,
RNN states and their episode starts, rewards (shaped), terminations and dones, and on a time-out the
value to bootstrap from (``value_bootstrap``); the env's step outcome (episode statistics, success,
callbacks) goes to the run through :meth:`RunContext.record_step`. With a central value the values and
the bootstrap come from it, and its RNN states ride along after the model's.

Two ways, the same transitions: synchronous (act for all envs, step all, observe all), or pipelined over
env groups (``env.env_groups`` with ``send``/``recv``, envpool with ``env_groups`` > 1), where one group's
env step runs in the background while the collector takes the other group's result and computes its
actions. :meth:`OnPolicyCollector._act` and :meth:`OnPolicyCollector._observe` work on a slice of env
rows, so both ways share them. PPO collects with it; so can a user's on-policy algorithm.
"""

from __future__ import annotations

import time
from typing import Any, Protocol

import numpy as np
import torch

from rlchain.algos.base.safety import check_obs_shape
from rlchain.algos.core.returns import shape_rewards
from rlchain.algos.core.storage import ALL
from rlchain.envs.vecenv import dropped_rows
from rlchain.networks.rnn import zero_finished


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


class OnPolicyCollector:
    """Collects rollouts of ``model`` on ``env`` into ``storage`` for the run ``ctx`` (its RunContext).

    ``cfg`` (the run's config) gives ``horizon_length``, ``reward_shaper`` and ``gamma``, and where it
    has them (PPO's keys) ``value_bootstrap`` (default False), ``timeout_bootstrap`` and
    ``zero_rnn_on_done``; ``central_value`` (optional) gives the values and adds its RNN states after the
    model's; ``use_masks`` asks the env for action masks every step. Between rollouts it holds where the
    envs stand: :attr:`obs` (the next observations, set by the algorithm's ``start``), :attr:`rnn_states`
    and :attr:`resets` (their episode starts); after a rollout :attr:`last_values` holds the values of the
    next observations (raw scale), for the returns.
    """

    def __init__(self, env: Any, model: Any, ctx: Any, cfg: Any, *, storage: Any = None, central_value: Any = None,
                 use_masks: bool = False, pipeline_choice: PipelineChoice | None = None) -> None:
        self.env, self.model, self.ctx, self.cfg = env, model, ctx, cfg
        self.storage, self.central_value, self.use_masks = storage, central_value, use_masks
        self.pipeline_choice: PipelineChoice = pipeline_choice or AlwaysPipelined()
        self.graphed_act: Any = None
        """``cuda_graph``: the act step captured as a CUDA graph (rlchain.algos.ppo.graph_step.GraphedAct)."""
        self.num_envs, self.device = env.num_envs, ctx.device
        self.obs: Any = None
        self.rnn_states: tuple[torch.Tensor, ...] = ()
        self.resets = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        self.last_values: torch.Tensor | None = None
        self.reward_bonus: Any = None
        """Optional: (next observations of a step's rows) -> (rows, 1) rewards added to the shaped env reward
        (PPO's ``rnd``)."""
        self.fold_obs_each_step = False
        """Fold each step's next observations into the model's (and central value's) input statistics as they
        come (``obs_normalizer_update: step``, rsl_rl's timing)."""

    def initial_states(self) -> tuple[torch.Tensor, ...]:
        """Zero RNN states for every env: the model's, then the central value's."""
        states = tuple(self.model.initial_state(self.num_envs, self.device))
        if self.central_value is not None:
            states += self.central_value.initial_state(self.num_envs, self.device)
        return states

    def reset_states(self) -> None:
        """Fresh episodes everywhere: zero RNN states, every row starts an episode."""
        self.rnn_states = self.initial_states()
        self.resets.fill_(True)

    def _action_masks(self) -> torch.Tensor | None:
        """(N, mask_size) bool masks of valid actions from the env, when use_action_masks is on."""
        if not self.use_masks:
            return None
        return self.ctx.to_tensor(self.env.get_action_mask()).bool()

    def rollout(self) -> bool:
        """Step the envs for horizon_length steps, filling the storage; False if a stop signal came. Over env
        groups, pipelined or stepped together as :attr:`pipeline_choice` says (the same transitions)."""
        self.model.eval()
        groups = self.ctx.spec.groups
        if groups is None or len(groups) < 2:
            return self._rollout()
        pipelined = self.pipeline_choice.pipelined()
        start = time.perf_counter()
        complete = self._pipelined_rollout(groups) if pipelined else self._rollout()
        if complete:
            self.pipeline_choice.record(pipelined, time.perf_counter() - start)
        return complete

    def _rollout(self) -> bool:
        """The synchronous rollout: act for every env, step them all, observe them all."""
        for t in range(self.cfg.horizon_length):
            if self.ctx.stop_requested():
                return False
            pending, actions = self._act(t, ALL)
            result = self.env.step(actions)
            if self.ctx.epoch == 0 and t == 0:
                check_obs_shape(result.obs, self.num_envs, self.env.observation_space, "env step")
            self._observe(t, ALL, result, *pending)
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

        for t in range(self.cfg.horizon_length):
            if self.ctx.stop_requested():
                drain(t - 1)
                return False
            for g, rows in enumerate(groups):
                if pending[g] is not None:
                    self._observe(t - 1, rows, self.env.recv(g), *pending[g])
                pending[g], actions = self._act(t, rows)
                self.env.send(g, actions)
        drain(self.cfg.horizon_length - 1)
        self.last_values = self._value(self.obs, self.rnn_states)
        return True

    def _act(self, t: int, rows: slice) -> tuple[tuple, Any]:
        """Policy step t for the envs ``rows``: record obs, actions, values and states in the storage.

        Returns ((values, next RNN states) for :meth:`_observe`, the actions in the env's format).
        """
        model = self.model
        obs, states, resets = self.obs, self.rnn_states, self.resets
        if rows is not ALL:
            obs, resets, states = obs[rows], resets[rows], tuple(s[:, rows] for s in states)
        masks = self._action_masks()
        if self.graphed_act is not None and rows is ALL:  # cuda_graph: feed-forward, no masks, every env
            out = self.graphed_act(obs)
        else:
            out = model.act(obs, states=states, action_masks=masks)
        next_states = tuple(out["states"] or ())
        values = out["values"]
        if self.central_value is not None:
            values, cv_states = self.central_value.step(obs, states[model.num_states:])
            next_states += cv_states
        self.storage.add(t, obs, out["actions"], out["log_probs"], values, out["params"], masks,
                         states, resets, rows=rows)
        return (values, next_states), self.ctx.env_actions(model.dist.to_env(out["actions"]))

    def _observe(self, t: int, rows: slice, result: Any, values: torch.Tensor, next_states: tuple) -> None:
        """The env's answer to step t for the envs ``rows``: rewards, dones and bootstrap values into
        the storage, episode statistics, then the next obs and RNN states."""
        cfg, storage = self.cfg, self.storage
        bootstrap = getattr(cfg, "value_bootstrap", False)  # PPO's keys; another algorithm's config may lack them
        rewards, terminated, truncated, dones = self.ctx.record_step(result, rows)
        if rewards.dim() == 1:
            rewards = rewards.unsqueeze(-1)
        rs = cfg.reward_shaper
        shaped = shape_rewards(rewards, rs.scale_value, rs.shift_value, rs.min_val, rs.max_val, rs.log_val)
        if self.reward_bonus is not None:  # e.g. PPO's rnd: an intrinsic reward of the next observation (rsl_rl)
            shaped = shaped + self.reward_bonus(result.obs)
        dropped = dropped_rows(result)
        if dropped is not None and bool(np.any(dropped)):  # a dead Ray worker's envs: zero advantage
            lost = self.ctx.to_tensor(np.asarray(dropped)).bool()
            shaped[lost] = values[lost] * ((1 - cfg.gamma) if bootstrap else 1.0)
        if bootstrap and bool(truncated.any()):
            idx = (truncated & ~terminated).nonzero().squeeze(-1)
            previous = getattr(cfg, "timeout_bootstrap", "final_obs") == "previous_value"
            if idx.numel() and previous:  # rl_games: V(s_t), no extra pass
                storage.final_values[t, rows][idx] = values[idx]
            elif idx.numel():
                final_obs = self.ctx.to_tensor(result.final_obs)[idx]
                row_states = tuple(s[:, idx] for s in next_states)
                storage.final_values[t, rows][idx] = self._value(final_obs, row_states)
        storage.add_outcome(t, shaped, terminated if bootstrap else dones, dones, rows=rows)
        obs = self.ctx.to_tensor(result.obs)
        if self.fold_obs_each_step:  # obs_normalizer_update step: rsl_rl's timing
            with torch.no_grad():
                self.model.update_normalizers(obs=obs)
                if self.central_value is not None:
                    self.central_value.update_normalizers(obs=obs)
        if next_states and getattr(cfg, "zero_rnn_on_done", True):
            next_states = zero_finished(next_states, dones)
        if rows is ALL:
            self.obs = obs
            if next_states:
                self.rnn_states, self.resets = next_states, dones
            return
        self.obs[rows] = obs
        if next_states:
            for state, new in zip(self.rnn_states, next_states):
                state[:, rows] = new
            self.resets[rows] = dones

    def _value(self, obs: torch.Tensor, states: tuple) -> torch.Tensor:
        """Raw-scale values of ``obs``: the central value's when there is one, else the model's."""
        if self.central_value is not None:
            return self.central_value.value(obs, states[self.model.num_states:])
        return self.model.value(obs, states)
