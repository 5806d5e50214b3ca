"""The PPO rollout: step the envs for horizon_length steps and fill the RolloutStorage.

Two ways, the same transitions: synchronous (act for all envs, step all, observe all), or
pipelined over env groups (``env.env_groups`` with ``send``/``recv``, envpool with ``env_groups`` >
1), where one group's env step runs in the background while the trainer takes the other group's
result and computes its actions. :meth:`RolloutMixin._act` and :meth:`RolloutMixin._observe` work
on a slice of env rows, so both ways share them.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from rlchain.algos.base.safety import check_obs_shape
from rlchain.algos.core.returns import shape_rewards
from rlchain.algos.core.storage import ALL
from rlchain.envs.vecenv import dropped_rows
from rlchain.networks.rnn import zero_finished

if TYPE_CHECKING:
    from rlchain.algos.ppo.env_layout import PipelineChoice


class RolloutMixin:
    """The rollout half of :class:`rlchain.algos.ppo.trainer.OnPolicyTrainer` (uses its env, model,
    storage, central value, RNN states and run context)."""

    graphed_act = None
    """``cuda_graph``: the act step captured as a CUDA graph (rlchain.algos.ppo.graph_step.GraphedAct)."""
    pipeline_choice: PipelineChoice
    """Over env groups: pipelined, or stepped together (``env_groups: auto`` measures; rlchain.algos.ppo.env_layout)."""

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
        step it, the trainer takes the other group's result and computes that group's actions. Each
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
        rewards, terminated, truncated, dones = self.ctx.env_outcome(result, rows)
        if rewards.dim() == 1:
            rewards = rewards.unsqueeze(-1)
        rs = cfg.reward_shaper
        shaped = shape_rewards(rewards, rs.scale_value, rs.shift_value, rs.min_val, rs.max_val, rs.log_val)
        if getattr(self, "rnd", None) is not None:  # rnd: the intrinsic reward of the next observation (rsl_rl)
            shaped = shaped + self.intrinsic_reward(result.obs)
        dropped = dropped_rows(result)
        if dropped is not None and bool(np.any(dropped)):  # a dead Ray worker's envs: zero advantage
            lost = self.ctx.to_tensor(np.asarray(dropped)).bool()
            shaped[lost] = values[lost] * ((1 - cfg.gamma) if cfg.value_bootstrap else 1.0)
        if cfg.value_bootstrap and bool(truncated.any()):
            idx = (truncated & ~terminated).nonzero().squeeze(-1)
            if idx.numel() and cfg.timeout_bootstrap == "previous_value":  # rl_games: V(s_t), no extra pass
                storage.final_values[t, rows][idx] = values[idx]
            elif idx.numel():
                final_obs = self.ctx.to_tensor(result.final_obs)[idx]
                row_states = tuple(s[:, idx] for s in next_states)
                storage.final_values[t, rows][idx] = self._value(final_obs, row_states)
        storage.add_outcome(t, shaped, terminated if cfg.value_bootstrap else dones, dones, rows=rows)
        obs = self.ctx.to_tensor(result.obs)
        if getattr(self, "fold_obs_each_step", False):  # obs_normalizer_update step: rsl_rl's timing
            with torch.no_grad():
                self.model.update_normalizers(obs=obs)
                if self.central_value is not None:
                    self.central_value.update_normalizers(obs=obs)
        if next_states and cfg.zero_rnn_on_done:
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
