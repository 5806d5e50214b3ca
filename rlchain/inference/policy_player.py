"""``--play`` for ``config.multi_agent``: every policy plays its agents; per-policy episode rewards.

A game is one env episode (every agent done); each policy's mean reward is over its agents'
episodes (an agent that left early counts its own shorter episode).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from rlchain.config.params import Params
from rlchain.envs.factory import build_env
from rlchain.envs.spec import env_spec
from rlchain.models.build import policy_agents
from rlchain.models.seats import seats_of
from rlchain.parallel.device import resolve_device
from rlchain.policy.load import LoadedPolicy, load_policy
from rlchain.policy.play import step_policies


@dataclass
class PoliciesPlayResult:
    """Games played; each policy's mean episode reward and its agent-episodes' returns."""

    games: int
    mean_rewards: dict[str, float]
    rewards: dict[str, list[float]] = field(default_factory=dict)

    @property
    def mean_reward(self) -> float:
        """Over every agent-episode of every policy (what training reports as ``rewards/step``)."""
        every = [r for returns in self.rewards.values() for r in returns]
        return float(np.mean(every)) if every else float("nan")


def play_policies(params: Params, checkpoint: str | None, games: int | None = None,
                  deterministic: bool | None = None, quiet: bool = False,
                  models: torch.nn.ModuleDict | None = None) -> PoliciesPlayResult:
    """Play ``games`` env episodes (default player.games_num) with every policy of the checkpoint
    (or of ``models``); returns each policy's mean agent-episode reward."""
    pc = params.config.player
    games = games or pc.games_num
    deterministic = pc.deterministic if deterministic is None else deterministic
    num_envs = pc.num_actors if pc.use_vecenv else 1
    if models is None:
        policy = load_policy(params, checkpoint, num_envs=num_envs, render=pc.render, env_config=pc.env_config)
    else:  # the given models on a fresh env
        device = resolve_device(params.config.device)
        seed = params.seed if params.seed is not None else 0
        env = build_env(params, num_envs, seed, render=pc.render, env_config=pc.env_config)
        policy = LoadedPolicy(models.eval(), env, device, None)
    try:
        return _play(params, policy.env, policy.model, games, deterministic, policy.device, quiet)
    finally:
        policy.close()


def _play(params: Params, env: object, models: torch.nn.ModuleDict, games: int, deterministic: bool,
          device: torch.device, quiet: bool) -> PoliciesPlayResult:
    plan = {name: agents for name, agents in policy_agents(params, env).items() if agents}
    returns = {a: np.zeros(env.num_envs) for a in env.agent_ids}
    finished: dict[str, list[float]] = {name: [] for name in plan}
    played = 0
    seed = params.seed if params.seed is not None else 0
    seats = seats_of(params, env, seed)  # the policy of each agent in each env's current episode
    for result in step_policies(env, models, plan, device, deterministic, seed, seats=seats):
        for a in env.agent_ids:
            returns[a] += result.reward[a]
            done = result.terminated[a] | result.truncated[a]
            for i in done.nonzero()[0].tolist():
                finished[seats.policy_of(a, i)].append(float(returns[a][i]))
            returns[a][done] = 0.0
        played += env.pop_games() if env_spec(env).games_counter else 0
        if played >= games:
            break
    means = {name: float(np.mean(r)) if r else float("nan") for name, r in finished.items()}
    if not quiet:
        text = ", ".join(f"{name} {value:.2f}" for name, value in means.items())
        print(f"av reward per policy: {text} over {played} games", flush=True)
    return PoliciesPlayResult(played, means, finished)
