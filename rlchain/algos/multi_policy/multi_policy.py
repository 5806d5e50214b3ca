"""Multi-policy PPO: PettingZoo agents, each played by the policy the mapping names.

Every policy has its own model, optimizer, normalizers, rollout storage, adaptive lr and tags
(``rewards/<policy>/...``, ``losses/<policy>/...``, ``info/<policy>/...``); they share the env
steps. A rollout step asks every policy for its agents' actions, steps the envs once, and hands
each policy its agents' rewards and ends. Steps where an agent was not there or not on turn are
inactive: :mod:`rlchain.algos.multi_policy.masked` leaves them out of returns, loss and statistics. Policies
left out of ``policies_to_train`` act without learning (a frozen opponent, a snapshot for self-play).

An agent the mapping gives a list of policies (a random opponent per episode) has a row in each of them; at each
episode start :class:`~rlchain.models.seats.Seats` picks the one that plays it there, and the other policies'
rows of that agent are inactive for that episode, their rewards and ends not theirs. A mapping without lists
does none of this work.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import torch

from rlchain.algos.base.algorithm import AlgorithmBase
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import DivergenceGuard, check_rollout
from rlchain.algos.core.collector import CollectedStep, OnPolicyCollector, as_is, no_record
from rlchain.algos.core.returns import shape_with
from rlchain.algos.multi_policy.masked import MaskedPPOAgent, masked_gae
from rlchain.algos.multi_policy.policies import PolicyAgents, PolicyLearner
from rlchain.algos.multi_policy.snapshots import Snapshots
from rlchain.config.actor_critic import check_batch
from rlchain.config.errors import ConfigError
from rlchain.config.multi_agent import KEY
from rlchain.config.params import Params
from rlchain.envs.spec import EnvSpec
from rlchain.envs.vecenv import VecEnv
from rlchain.models.build import policy_agents
from rlchain.models.seats import seats_of

STAT_TAGS = {"a_loss": "losses/{}/a_loss", "c_loss": "losses/{}/c_loss", "entropy": "losses/{}/entropy",
             "b_loss": "losses/{}/bounds_loss", "lr": "info/{}/last_lr", "kl": "info/{}/kl",
             "entropy_coef": "info/{}/entropy_coef", "clip_frac": "info/{}/clip_frac"}


class MultiPolicyPPO(AlgorithmBase):
    """PPO for several policies over one PettingZoo vector env (``config.multi_agent``); self_play_config
    acts through ``multi_agent.snapshots`` (:class:`Snapshots`, driven from :meth:`end_epoch`)."""

    agent_class: type[MaskedPPOAgent] = MaskedPPOAgent
    """Each trained policy's learner (appo / impala: :mod:`rlchain.algos.multi_policy.vtrace_policies`)."""

    @classmethod
    def check_config(cls, params: Params, spec: EnvSpec) -> None:
        """Features single-policy PPO has and this one not yet; the minibatch against the batch."""
        _check_supported(params)
        check_batch(params.config, params.source, spec.num_agents)

    def __init__(self, params: Params, env: VecEnv, model: torch.nn.ModuleDict, ctx: RunContext) -> None:
        super().__init__(params, env, model, ctx)
        device = self.device
        if ctx.comm.active:
            raise ConfigError(params.source, "params.config.multi_gpu", "is not supported with multi_agent yet")
        ma = self.cfg.multi_agent
        to_train = set(ma.policies_to_train if ma.policies_to_train is not None else params.policies)
        self.policies: list[PolicyLearner] = []
        for name, agents in policy_agents(params, env).items():
            if not agents:
                continue
            policy = params.policies[name]
            if policy.config.use_action_masks and not env.mask_sizes[agents[0]]:
                raise ConfigError(params.source, f"{KEY}.policies.{name}", f"use_action_masks is True but agent "
                                  f"'{agents[0]}' has no action_mask in its observations")
            self.policies.append(PolicyLearner(name, policy, agents, model[name],
                                               env.observation_spaces[agents[0]].shape, env.num_envs,
                                               name in to_train, device, self.cfg.games_to_track,
                                               self.agent_class))
        self.agent = PolicyAgents(self.policies)
        self._recurrent = any(lr.states for lr in self.policies)
        self.seats = seats_of(params, env, ctx.seed)  # which policy plays a listed agent, episode by episode
        self._agent_rows = None  # with listed agents: each policy row's row of the run-wide (agent, env) statistics
        if self.seats.dynamic:
            order, e = list(env.agent_ids), env.num_envs
            self._agent_rows = torch.cat([torch.arange(e, device=device) + order.index(a) * e
                                          for lr in self.policies for a in lr.agents])
        self.divergence = DivergenceGuard(self.cfg.divergence, model, self.agent)
        # the env takes and gives per-agent dicts: the policies act, record and read them (no run-wide storage)
        self.collector = OnPolicyCollector(env, model, ctx, self.cfg, act=self._act, to_env=as_is,
                                           record=no_record, read_obs=as_is, on_step=self._on_step)
        self.snapshots = None
        if self.cfg.self_play_config is not None:
            recurrent = [name for name in ma.snapshots if any(lr.states for lr in self.policies if lr.name == name)]
            if recurrent:
                raise ConfigError(params.source, f"{KEY}.snapshots.{recurrent[0]}", "a self-play snapshot plays "
                                  "without RNN states: snapshots of recurrent policies are not supported")
            self.snapshots = Snapshots(self.cfg.self_play_config, ma.snapshots, params.source)

    def learner(self, name: str) -> PolicyLearner:
        """The policy ``name``'s learner (KeyError naming the policies otherwise)."""
        for lr in self.policies:
            if lr.name == name:
                return lr
        raise KeyError(f"no policy '{name}' plays in this env (policies: {[lr.name for lr in self.policies]})")

    # ----- the Algorithm hooks --------------------------------------------------------------
    def collect(self) -> bool:
        """horizon_length env steps (the on-policy collector); every trained policy's storage gets its agents'
        rows."""
        if not self.collector.rollout():  # per-agent views, as the env gives them
            return False
        for lr in self.policies:
            lr.end_rollout(self.collector.obs)
        return True

    def _act(self, t: int, views: Any, states: tuple, env_masks: Any) -> dict[str, Any]:
        """The collector's act step: every policy acts for its agents (a self-play snapshot for each env's
        own); a trained policy's step t goes into its storage. ``out["actions"]``: the env's per-agent dict;
        ``out["owned"]``: each policy's rows it plays this episode (None: all)."""
        actions, acted, owned = {}, [], []
        for lr in self.policies:
            obs, active, masks = lr.gather(views)
            own = self.seats.owned(lr.name, lr.agents) if self.seats.dynamic else None
            if own is not None:
                own = torch.as_tensor(own, device=self.device)
                active = active & own
            acted.append(active)
            owned.append(own)
            pool = self.snapshots.pools.get(lr.name) if self.snapshots is not None else None
            if pool is not None:  # a self-play snapshot: each env's own
                with torch.no_grad():
                    env_actions = pool.act(obs, len(lr.agents), masks)
                lr.put(actions, lr.model.dist.to_env(env_actions).cpu().numpy(), own)
                continue
            with torch.no_grad():
                out = lr.model.act(obs, states=lr.states or None, action_masks=masks)
            if lr.agent is not None:
                lr.storage.add(t, obs, out["actions"], out["log_probs"], out["values"], out["params"], masks,
                               states=lr.states, resets=lr.resets if lr.states else None)
                lr.active[t] = active
            lr.advance(out["states"])
            lr.put(actions, lr.model.dist.to_env(out["actions"]).cpu().numpy(), own)
        return {"actions": actions, "acted": acted, "owned": owned}

    def _on_step(self, step: CollectedStep) -> None:
        """The collector's per-step hook: each policy's rewards and ends (:meth:`_observe`); the policies of
        the listed agents in the envs that start a new episode."""
        self._observe(step.t, step.result, step.out["acted"], step.out["owned"])
        if self._recurrent:
            started = torch.as_tensor(step.result.started, device=self.device)
            for lr in self.policies:
                lr.start_episodes(started)
        if self.seats.dynamic:
            self.seats.draw(step.result.started.nonzero()[0], self.env.named_policies)

    def _observe(self, t: int, result: Any, acted: list[torch.Tensor], owned: list[torch.Tensor | None]) -> None:
        """Rewards and ends of step t into each policy's storage and episode statistics (of the rows it plays)."""
        all_rewards, all_dones = [], []
        for lr, active, own in zip(self.policies, acted, owned):
            rewards = lr.outcome(result.reward).float()
            terminated, truncated = lr.outcome(result.terminated).bool(), lr.outcome(result.truncated).bool()
            if own is not None:  # another policy's episode on these rows
                rewards, terminated, truncated = rewards * own, terminated & own, truncated & own
            dones = terminated | truncated
            lr.tracker.agent_step(rewards, dones, active)
            all_rewards.append(rewards)
            all_dones.append(dones)
            if lr.agent is None:
                continue
            cfg = lr.cfg
            rs = cfg.reward_shaper
            shaped = shape_with(rewards.unsqueeze(-1), rs)
            if cfg.value_bootstrap and bool(truncated.any()):
                idx = (truncated & ~terminated).nonzero().squeeze(-1)
                if idx.numel():
                    final = lr.outcome(result.final_obs).float()[idx]
                    states = tuple(s[:, idx] for s in lr.states) or None
                    with torch.no_grad():
                        lr.storage.final_values[t][idx] = lr.model.value(final, states)
            lr.storage.add_outcome(t, shaped, terminated if cfg.value_bootstrap else dones, dones)
        rewards, dones, active = torch.cat(all_rewards), torch.cat(all_dones), torch.cat(acted)
        if self._agent_rows is not None:  # a listed agent's rows in several policies: one row per agent and env
            rows, size = self._agent_rows, self.ctx.tracker.returns.shape[0]
            rewards = torch.zeros(size, device=rows.device).index_add_(0, rows, rewards)
            dones = torch.zeros(size, dtype=torch.long, device=rows.device).index_add_(0, rows, dones.long()) > 0
            active = torch.zeros(size, dtype=torch.long, device=rows.device).index_add_(0, rows, active.long()) > 0
        self.ctx.tracker.agent_step(rewards, dones, active)

    def update(self) -> dict[str, float]:
        """Masked GAE, normalizers and a PPO update for every trained policy."""
        stats: dict[str, float] = {}
        for lr in self.policies:
            if lr.agent is None:
                continue
            storage = lr.storage
            check_rollout(storage.rewards, storage.obs, f"policy {lr.name}: ")
            if not bool(lr.active.any()):
                continue
            model = lr.model
            with torch.no_grad():  # advantages over the active steps, then the policy's normalizers fold them in
                adv, returns = self.advantages(lr)
                storage.advantages.copy_(adv)
                storage.returns.copy_(returns)
                storage.final_values.zero_()
                flat = lr.active.reshape(-1)
                model.update_normalizers(obs=storage.obs.reshape(-1, *storage.obs.shape[2:])[flat],
                                         returns=returns.reshape(-1, returns.shape[-1])[flat],
                                         values=storage.values.reshape(-1, storage.values.shape[-1])[flat])
            model.train()
            for key, value in lr.agent.update(storage, self.progress()).items():
                if key in STAT_TAGS:
                    stats[STAT_TAGS[key].format(lr.name)] = value
                    if len(self.policies) == 1:  # one shared policy: rl_games' own tags too
                        stats[self.plain_tag(key)] = value
        return stats

    def advantages(self, lr: PolicyLearner) -> tuple[torch.Tensor, torch.Tensor]:
        """(advantages, returns) of a trained policy's rollout: GAE over its active steps."""
        storage, cfg = lr.storage, lr.cfg
        return masked_gae(storage.rewards, storage.values, storage.final_values, lr.last_values, lr.active,
                          storage.terminated, storage.dones, cfg.gamma, cfg.tau)

    @staticmethod
    def plain_tag(key: str) -> str:
        return STAT_TAGS[key].replace("{}/", "")

    def frames_per_epoch(self) -> int:
        """Env steps per epoch (a turn-based env's step is one move)."""
        return self.cfg.horizon_length * self.num_envs

    # ----- per-agent observations, per-policy statistics ---------------------------------------
    def start(self) -> None:
        """Reset the envs (per-agent observations, as the env gives them); self-play snapshots start."""
        self.collector.place(self.ctx.reset_raw())
        self._new_episodes()
        if self.snapshots is not None:
            self.snapshots.start(self)

    def _new_episodes(self) -> None:
        """Every env starts an episode: the listed agents' policies are drawn, RNN states start from zero."""
        self.seats.draw(np.arange(self.num_envs), self.env.named_policies)
        for lr in self.policies:
            lr.start_episodes(torch.ones(self.num_envs, dtype=torch.bool, device=self.device))

    def restart_episodes(self) -> None:
        self.ctx.tracker.reset_running()
        self.collector.place(self.ctx.reset_raw())
        self._new_episodes()
        for lr in self.policies:
            lr.tracker.reset_running()

    def end_epoch(self, stats: dict[str, float], episodes: dict | None) -> None:
        """Each policy's ``rewards/<policy>/{step,iter,time}`` after the Loop's epoch line and tags; then
        the self-play snapshots' refresh rule."""
        ctx = self.ctx
        elapsed = int(time.time() - ctx.logger.start)
        for lr in self.policies:
            if not lr.tracker.has_data:
                continue
            for name, value in (("rewards", lr.tracker.mean_return()), ("episode_lengths", lr.tracker.mean_length())):
                ctx.logger.scalar(f"{name}/{lr.name}/step", value, ctx.frames)
                ctx.logger.scalar(f"{name}/{lr.name}/iter", value, ctx.epoch)
                ctx.logger.scalar(f"{name}/{lr.name}/time", value, elapsed)
        if self.snapshots is not None:
            self.snapshots.end_epoch(self)

    # ----- checkpoints ----------------------------------------------------------------------
    def extra_state(self, kind: str) -> dict:
        """Each policy's episode statistics (the models and optimizers travel as model / agent)."""
        return {"policy_episodes": {lr.name: lr.tracker.state_dict() for lr in self.policies},
                "policies": [lr.name for lr in self.policies], "seats": self.seats.state_dict()}

    def restore_extra(self, state: dict) -> None:
        self.seats.load_state_dict(state.get("seats") or {})
        saved = state.get("policy_episodes", {})
        for lr in self.policies:
            if lr.name in saved:
                lr.tracker.load_state_dict(saved[lr.name])


def _check_supported(params: Params) -> None:
    """Features of single-policy PPO multi_agent does not have yet: a one-line ConfigError."""
    cfg = params.config
    unsupported = [("central_value_config", cfg.central_value_config is not None),
                   ("evaluation.interval", cfg.evaluation.interval > 0),
                   ("torch_compile", bool(cfg.torch_compile)),
                   ("compile_update", cfg.compile_update),
                   ("cuda_graph", cfg.cuda_graph is True),  # auto: eager
                   ("obs_normalizer_update", cfg.obs_normalizer_update in ("minibatch", "step")),  # auto: rollout
                   ("env_runners", cfg.env_runners is not None or str(cfg.vecenv_type).lower() == "ray")]
    for key, used in unsupported:
        if used:
            raise ConfigError(params.source, f"params.config.{key}", "is not supported with multi_agent yet; "
                                                                     "remove it (docs/multi_agent.md)")
