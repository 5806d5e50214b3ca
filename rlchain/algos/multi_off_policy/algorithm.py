"""Multi-policy DQN and SAC (``algo: dqn`` / ``sac`` with ``config.multi_agent``): PettingZoo agents, each played
by the policy the mapping names, every policy its own off-policy agent.

Each policy has its own model, replay buffer, target networks, optimizers and settings (its ``multi_agent.policies
.<name>.config``); they share the env steps of one PettingZoo vector env. An env step asks every policy for its
agents' actions (uniform while its warmup lasts), steps the envs once, and hands each policy its agents' shaped
rewards and ends. A policy stores only its agents' transitions, from an agent's step to its next active step with
the rewards in between summed (:mod:`rlchain.algos.multi_off_policy.transitions`), and after every
``update_every``-th env step runs ``num_updates_per_step`` updates of its single-agent agent, as its single-agent
algorithm does (:mod:`rlchain.algos.off_policy.off_policy`). Policies left out of ``policies_to_train`` act
without learning. Results per policy: ``losses/<policy>/...``, ``info/<policy>/...``, ``rewards/<policy>/...``.
"""

from __future__ import annotations

import time
from typing import Any

import torch

from rlchain.algos.base.algorithm import AlgorithmBase
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import DivergenceGuard
from rlchain.algos.core.collector import CollectedStep, OnPolicyCollector, as_is, no_record
from rlchain.algos.core.returns import shape_with
from rlchain.algos.multi_off_policy.learner import SINGLE, OffPolicyLearner, policy_tag
from rlchain.algos.multi_policy.policies import PolicyAgents
from rlchain.algos.off_policy.off_policy import UpdatesInCollect
from rlchain.config.errors import ConfigError
from rlchain.config.multi_agent import KEY
from rlchain.config.params import Params
from rlchain.envs.spec import EnvSpec
from rlchain.envs.vecenv import VecEnv
from rlchain.errors import DivergenceError
from rlchain.models.build import policy_agents


class MultiPolicyOffPolicy(UpdatesInCollect, AlgorithmBase):
    """DQN or SAC (``params.algo.name``) for several policies over one PettingZoo vector env."""

    @classmethod
    def check_config(cls, params: Params, spec: EnvSpec) -> None:
        check_supported(params)

    def __init__(self, params: Params, env: VecEnv, model: torch.nn.ModuleDict, ctx: RunContext) -> None:
        super().__init__(params, env, model, ctx)
        if ctx.comm.active:
            raise ConfigError(params.source, "params.config.multi_gpu", "is not supported with multi_agent yet")
        ma = self.cfg.multi_agent
        to_train = set(ma.policies_to_train if ma.policies_to_train is not None else params.policies)
        self.policies: list[OffPolicyLearner] = []
        for name, agents in policy_agents(params, env).items():
            if agents:
                self.policies.append(OffPolicyLearner(name, params.policies[name], agents, model[name],
                                                      env.observation_spaces[agents[0]].shape, env.num_envs,
                                                      name in to_train, self.device, self.cfg.games_to_track))
        self.agent = PolicyAgents(self.policies)
        self.divergence = DivergenceGuard(self.cfg.divergence, model, self.agent)
        single = SINGLE[params.algo.name]
        # update()'s statistics are ``<policy>.<name>``: the tagged ones logged per policy, the others for callbacks
        self.metric_tags = {f"{lr.name}.{key}": policy_tag(tag, lr.name) for lr in self.policies
                            for key, tag in single.metric_tags.items()}
        # one env step per rollout; the env takes and gives per-agent dicts, the policies act and record them
        self.collector = OnPolicyCollector(env, model, ctx, self.cfg, horizon=1, act=self._act, to_env=as_is,
                                           record=no_record, read_obs=as_is, on_step=self._on_step)
        self._epoch_stats: dict[str, float] = {}
        self._update_s = 0.0
        self._stepped = 0  # env steps of this epoch so far (the Loop counts the epoch's frames after its update)

    @property
    def frames(self) -> int:
        """The run's frames so far, this epoch's steps included (warmup, epsilon and update rounds read them)."""
        return self.ctx.frames + self._stepped * self.num_envs

    def learner(self, name: str) -> OffPolicyLearner:
        """The policy ``name``'s learner (KeyError naming the policies otherwise)."""
        for lr in self.policies:
            if lr.name == name:
                return lr
        raise KeyError(f"no policy '{name}' plays in this env (policies: {[lr.name for lr in self.policies]})")

    # ----- the Algorithm hooks --------------------------------------------------------------
    def start(self) -> None:
        self.collector.place(self.ctx.reset_raw())

    def collect(self) -> bool:
        """num_steps_per_episode env steps, each followed by the policies' update rounds (a stop signal waits for
        the epoch's end, as single-agent off-policy)."""
        sums: dict[str, dict[str, Any]] = {lr.name: {} for lr in self.policies}
        self._update_s = 0.0
        self._stepped = 0
        for _ in range(self.cfg.num_steps_per_episode):
            if not self.collector.rollout():  # one env step (a stop signal ends the run here)
                return False
            t0 = time.time()
            for lr in self.policies:
                if lr.agent is None or not self._round_due(lr):
                    continue
                with self.ctx.update_phase():
                    for k, v in lr.update_round(self.frames, self.progress()).items():
                        sums[lr.name][k] = sums[lr.name].get(k, 0) + v
            self._update_s += time.time() - t0
        self._epoch_stats = {}
        for lr in self.policies:
            count = sums[lr.name].pop("updates", 0)
            if lr.agent is None:
                continue
            stats = {k: float(v) / count for k, v in sums[lr.name].items()} if count else {}
            stats.update(lr.extra_stats(self.frames), lr=lr.agent.lr, total_updates=lr.agent.updates,
                         replay_size=len(lr.buffer), updates=count)
            self._epoch_stats.update({f"{lr.name}.{k}": v for k, v in stats.items()})
        return True

    def _round_due(self, lr: OffPolicyLearner) -> bool:
        every = lr.cfg.update_every
        return every == 1 or (self.frames // self.num_envs) % every == 0

    def _act(self, t: int, views: Any, states: tuple, env_masks: Any) -> dict[str, Any]:
        """The collector's act step: every policy acts for its agents; each trained policy's agents that act close
        their open transitions. ``out["actions"]``: the env's per-agent dict; ``out["acted"]``: each policy's
        active rows."""
        actions, acted = {}, []
        for lr in self.policies:
            obs, active, _ = lr.gather(views)
            with torch.no_grad():
                chosen = lr.actions(obs, self.frames)
            if lr.open is not None:
                lr.store(lr.open.act(obs, chosen, active))
                if bool(active.any()):
                    lr.model.update_normalizers(obs=obs[active])
            lr.put(actions, lr.model.dist.to_env(chosen).cpu().numpy(), None)
            acted.append(active)
        return {"actions": actions, "acted": acted}

    def _on_step(self, step: CollectedStep) -> None:
        """The collector's per-step hook: each policy's rewards (shaped into its open transitions) and its agents'
        ends (closing them); the run's and each policy's episode statistics."""
        result, acted = step.result, step.out["acted"]
        self._stepped += 1
        all_rewards, all_dones = [], []
        for lr, active in zip(self.policies, acted):
            rewards = lr.outcome(result.reward).float()
            terminated, truncated = lr.outcome(result.terminated).bool(), lr.outcome(result.truncated).bool()
            lr.tracker.agent_step(rewards, terminated | truncated, active)
            all_rewards.append(rewards)
            all_dones.append(terminated | truncated)
            if lr.open is None:
                continue
            shaped = shape_with(rewards, lr.cfg.reward_shaper)
            if not bool(torch.isfinite(shaped).all()):
                raise DivergenceError(f"policy {lr.name}: the env returned a non-finite reward")
            lr.store(lr.open.observe(shaped, terminated, truncated, lr.outcome(result.final_obs).float()))
        self.ctx.tracker.agent_step(torch.cat(all_rewards), torch.cat(all_dones), torch.cat(acted))

    def update(self) -> dict[str, float]:
        """The epoch's per-policy mean losses (the updates ran during :meth:`collect`), epsilon / alpha, lr, update
        counts and replay size, and the run's frames."""
        return {**self._epoch_stats, "frames": self.frames}

    def restart_episodes(self) -> None:
        self.ctx.tracker.reset_running()
        self.collector.place(self.ctx.reset_raw())
        for lr in self.policies:
            lr.tracker.reset_running()
            if lr.open is not None:
                lr.open.clear()
            if lr.nstep is not None:
                lr.nstep.clear()

    def end_epoch(self, stats: dict[str, float], episodes: dict | None) -> None:
        """Each policy's ``rewards/<policy>/{step,iter,time}`` and ``episode_lengths/<policy>/...``."""
        ctx = self.ctx
        elapsed = int(time.time() - ctx.logger.start)
        for lr in self.policies:
            if not lr.tracker.has_data:
                continue
            for name, value in (("rewards", lr.tracker.mean_return()), ("episode_lengths", lr.tracker.mean_length())):
                for axis, at in (("step", ctx.frames), ("iter", ctx.epoch), ("time", elapsed)):
                    ctx.logger.scalar(f"{name}/{lr.name}/{axis}", value, at)

    # ----- checkpoints ----------------------------------------------------------------------
    def extra_state(self, kind: str) -> dict:
        """Each policy's episode statistics, and with save_replay_buffer its replay buffer."""
        state: dict[str, Any] = {"policy_episodes": {lr.name: lr.tracker.state_dict() for lr in self.policies},
                                 "policies": [lr.name for lr in self.policies]}
        if self.cfg.save_replay_buffer:
            state["replay_buffers"] = {lr.name: lr.buffer.state_dict() for lr in self.policies if lr.buffer}
        return state

    def restore_extra(self, state: dict) -> None:
        saved, buffers = state.get("policy_episodes", {}), state.get("replay_buffers", {})
        for lr in self.policies:
            if lr.name in saved:
                lr.tracker.load_state_dict(saved[lr.name])
            if lr.buffer is not None and lr.name in buffers:
                lr.buffer.load_state_dict(buffers[lr.name])


def check_supported(params: Params) -> None:
    """Features multi-policy DQN / SAC do not have yet: a one-line ConfigError."""
    cfg, ma = params.config, params.config.multi_agent
    listed = [agent for agent, pids in ma.policy_mapping.items() if not isinstance(pids, str)]
    unsupported = [(f"{KEY}.snapshots", bool(ma.snapshots), "self-play snapshots are PPO only so far"),
                   (f"{KEY}.policy_mapping.{listed[0] if listed else ''}", bool(listed),
                    "a list of policies per episode is PPO only so far: map each agent to one policy"),
                   ("params.config.evaluation.interval", cfg.evaluation.interval > 0,
                    "is not supported with multi_agent yet; remove it"),
                   ("params.config.env_runners", getattr(cfg, "env_runners", None) is not None,
                    "is not supported with multi_agent yet; remove it")]
    for name, policy in (params.policies or {}).items():
        pc, path = policy.config, f"{KEY}.policies.{name}.config"
        unsupported.append((f"{path}.replay.her", pc.replay.her is not None, "hindsight replay is single-agent only"))
    for key, used, why in unsupported:
        if used:
            raise ConfigError(params.source, key, why)
