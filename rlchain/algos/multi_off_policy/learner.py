"""One policy of multi-policy DQN / SAC: its model, its agents' rows, and when it trains, the single-agent
algorithm's agent (:class:`~rlchain.algos.off_policy.dqn_agent.DQNAgent`,
:class:`~rlchain.algos.off_policy.sac_agent.SACAgent`: their update, unchanged), its own replay buffer and the
open transitions of its rows (:mod:`rlchain.algos.multi_off_policy.transitions`)."""

from __future__ import annotations

from typing import Any

import torch

from rlchain.algos.base.episodes import AgentEpisodes
from rlchain.algos.core.replay import ReplayBuffer
from rlchain.algos.multi_off_policy.transitions import NStepRows, OpenTransitions, Transitions
from rlchain.algos.multi_policy.policies import PolicyLearner
from rlchain.algos.off_policy.dqn import DQN
from rlchain.algos.off_policy.dqn_agent import DQNAgent, epsilon_at
from rlchain.algos.off_policy.sac import SAC
from rlchain.algos.off_policy.sac_agent import SACAgent
from rlchain.config.params import Params

AGENTS = {"dqn": DQNAgent, "sac": SACAgent}
"""algo name -> the single-agent agent every trained policy gets."""
SINGLE = {"dqn": DQN, "sac": SAC}
"""algo name -> the single-agent algorithm (its metric tags and console fields, per policy here)."""


class OffPolicyLearner(PolicyLearner):
    """One policy's rows (agent-major, as :class:`PolicyLearner`: row ``k * E + e`` is agent k of env e), acting
    and, when it trains, storing its agents' transitions and updating as its single-agent algorithm does."""

    def __init__(self, name: str, params: Params, agents: list[str], model: Any, obs_shape: tuple[int, ...],
                 num_envs: int, train: bool, device: torch.device, games_to_track: int) -> None:
        cfg = params.config
        self.name, self.params, self.cfg, self.agents, self.model = name, params, cfg, agents, model
        self.num_envs, self.rows, self.device = num_envs, num_envs * len(agents), device
        self.use_masks = False
        self.algo = params.algo.name
        self.tracker = AgentEpisodes(self.rows, games_to_track, device)
        self.agent = self.buffer = self.open = self.nstep = None
        if train:
            dist = model.dist
            self.agent = AGENTS[self.algo](model, cfg)
            self.buffer = ReplayBuffer(cfg.replay_buffer_size, tuple(obs_shape), tuple(dist.action_shape),
                                       device=device, num_envs=self.rows, action_dtype=dist.action_dtype,
                                       gamma=cfg.gamma, prioritized=cfg.prioritized_replay,
                                       alpha=cfg.priority_alpha, beta=cfg.priority_beta)
            self.open = OpenTransitions(self.rows, tuple(obs_shape), tuple(dist.action_shape), dist.action_dtype,
                                        device)
            if cfg.n_step > 1 or (cfg.n_step_max or 0) > cfg.n_step:  # n-step returns over each agent's own steps
                self.nstep = NStepRows(self.rows, cfg.n_step, cfg.n_step_max, cfg.gamma)

    def epsilon(self, frames: int) -> float:
        """DQN's exploration epsilon after ``frames`` env steps (the single-agent schedule)."""
        cfg = self.cfg
        return epsilon_at(frames - cfg.num_warmup_frames, cfg.epsilon_start, cfg.epsilon_end, cfg.epsilon_decay_frames)

    def actions(self, obs: torch.Tensor, frames: int) -> torch.Tensor:
        """The rows' actions (the model's format): uniform during warmup, else the model's exploring ones."""
        model = self.model
        if self.agent is not None and frames < self.cfg.num_warmup_frames:
            return model.dist.random(self.rows, self.device)
        model.eval()
        if self.algo == "dqn":
            return model.act(obs, epsilon=self.epsilon(frames) if self.agent is not None else None)["actions"]
        return model.act(obs)["actions"]

    def store(self, done: Transitions) -> None:
        """Finished transitions into the replay buffer (their rewards already shaped, step by step); with n-step
        returns, the n-step transitions they finish."""
        if not len(done):
            return
        if self.nstep is None:
            self.buffer.add(done.obs, done.actions, done.rewards, done.next_obs, done.terminated, done.truncated)
            return
        done, discounts = self.nstep.add(done)
        if len(done):
            self.buffer.add_discounted(done.obs, done.actions, done.rewards, done.next_obs, done.terminated,
                                       done.truncated, discounts)

    def update_round(self, frames: int, progress: float) -> dict[str, torch.Tensor]:
        """num_updates_per_step updates when warmup is over and the buffer holds a minibatch; summed stats.
        ``progress``: the run's, 0..1 (prioritized replay's importance exponent anneals over it)."""
        cfg, sums = self.cfg, {}
        beta = cfg.priority_beta + min(progress, 1.0) * (1.0 - cfg.priority_beta)
        if frames < cfg.num_warmup_frames or len(self.buffer) < cfg.batch_size:
            return sums
        self.model.train()
        for _ in range(cfg.num_updates_per_step):
            batch = self.buffer.sample(cfg.batch_size, beta=beta)
            stats, td = self.agent.update(batch)
            self.buffer.update_priorities(batch["indices"], td)
            for k, v in stats.items():
                sums[k] = sums.get(k, 0.0) + v
            sums["updates"] = sums.get("updates", 0) + 1
        return sums

    def extra_stats(self, frames: int) -> dict[str, float]:
        """What the single-agent algorithm adds to its losses: DQN's epsilon, SAC's alpha."""
        if self.algo == "dqn":
            return {"epsilon": self.epsilon(frames)}
        return {"alpha": float(self.model.alpha.detach())}


def policy_tag(tag: str, policy: str) -> str:
    """A single-agent tag under its policy: ``losses/td_loss`` -> ``losses/<policy>/td_loss``."""
    kind, _, name = tag.partition("/")
    return f"{kind}/{policy}/{name}"
