"""One loop that plays a fixed policy on a VecEnv: :func:`play`.

In-training evaluation (``training/evaluation.py``), the Player (``--play``, ``watch``), video
recording (``inference/video.py``, through a one-env VecEnv) and the env inputs of the ONNX parity check
(``export_inputs.env_rollout``) all play through it. It carries the policy's RNN state (zeroed
where an episode ended), fetches action masks when the policy uses them, counts whole games
(``game_reward`` / ``game_over``: Atari lives) and task success, one row = one game (multi-agent
envs: one per agent row).

Several policies on a PettingZoo env (``config.multi_agent``) play through :func:`step_policies`, the
same loop for each policy's agents: the multi-policy player and the per-policy ONNX export use it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from rlchain.envs.obs_dict import obs_as_tensor
from rlchain.envs.spec import env_spec
from rlchain.envs.vecenv import VecEnv, game_outcome
from rlchain.envs.wrappers.success import SuccessReader
from rlchain.models.seats import Seats
from rlchain.policy.stepper import PolicyStepper


@dataclass
class PlayResult:
    """Mean episode reward and length over the games played; ``successes`` (1.0 / 0.0) of the games
    for which the env reported task success (empty for envs that report none)."""

    games: int
    mean_reward: float
    mean_length: float
    rewards: list[float]
    successes: list[float] = field(default_factory=list)

    @property
    def success_rate(self) -> float | None:
        """Fraction of the games with a success value that succeeded; None when the env reports none."""
        return sum(self.successes) / len(self.successes) if self.successes else None


class EpisodeSuccess:
    """Per-env task success of the episodes in progress while playing (see ``envs/wrappers/success.py``)."""

    def __init__(self, num_envs: int, key: str, mode: str) -> None:
        self.reader = SuccessReader(key)
        self.mode = mode
        self.seen = np.zeros(num_envs, bool)
        self.any = np.zeros(num_envs, bool)
        self.last = np.zeros(num_envs, bool)

    def step(self, infos: Any, dones: Any) -> None:
        """Take in one step's ``infos`` and (N,) bool ``dones``."""
        values = self.reader.read(infos, dones)
        if values is None:
            return
        seen = ~np.isnan(values)
        hit = seen & (np.nan_to_num(values) > 0.5)
        self.seen |= seen
        self.any |= hit
        self.last[seen] = hit[seen]

    def pop(self, i: int) -> float | None:
        """Env ``i``'s finished episode: 1.0 / 0.0, or None without a success value; clears the row."""
        result = float((self.any if self.mode == "any" else self.last)[i]) if self.seen[i] else None
        self.seen[i] = self.any[i] = self.last[i] = False
        return result


class PolicySteps:
    """The play loop's step: ``env`` (reset with ``seed`` at the start) stepped with ``model``'s actions, one
    step per :meth:`step`; the RNN states are carried (zeroed where an episode ended) and the action masks
    fetched when the policy uses them (:class:`PolicyStepper`). :attr:`obs` holds the observations the next
    step acts on. :func:`play` is built on it; so is a probe that only times the env with a policy acting
    (rlchain.algos.ppo.env_layout)."""

    def __init__(self, model: Any, env: VecEnv, device: torch.device, deterministic: bool = True,
                 seed: int | None = None) -> None:
        self.model, self.env, self.device, self.deterministic = model, env, device, deterministic
        self.spec = env_spec(env)
        self.obs = obs_as_tensor(env.reset(seed=seed), device)
        self.policy = PolicyStepper(model, env.num_envs, device)
        self.use_masks = self.policy.uses_masks(self.spec)

    def masks(self) -> torch.Tensor | None:
        """The env's current action masks when the policy acts under masks, else None."""
        return self.policy.masks_from(self.env) if self.use_masks else None

    def step(self, masks: torch.Tensor | None = None) -> tuple[Any, torch.Tensor]:
        """Act on :attr:`obs` (under ``masks``), step the env; returns (its StepResult, (N,) bool CPU dones)."""
        actions = self.model.dist.to_env(self.policy.act(self.obs, deterministic=self.deterministic, masks=masks))
        result = self.env.step(self.spec.to_env(actions))
        done = (torch.as_tensor(result.terminated) | torch.as_tensor(result.truncated)).cpu()
        self.policy.done(done)
        self.obs = obs_as_tensor(result.obs, self.device)
        return result, done


def game_quota(games: int | None, num_envs: int) -> list[int] | None:
    """How many of the ``games`` each env plays: split evenly (the first envs take one more), so envs whose
    episodes end sooner are not over-counted, which would bias the mean towards short episodes (quick
    successes, early failures). None: no games limit."""
    return None if games is None else [(games + i) // num_envs for i in reversed(range(num_envs))]


GameHook = Callable[[int, float, int, "float | None"], None]
ObsHook = Callable[[torch.Tensor, "torch.Tensor | None"], None]


def play(model: Any, env: VecEnv, games: int | None, deterministic: bool = True, *,
         device: torch.device | None = None, seed: int | None = None, steps: int | None = None,
         on_game: GameHook | None = None, on_obs: ObsHook | None = None, render_sleep: float | None = None,
         success_key: str = "auto", success_mode: str = "any") -> PlayResult:
    """Play ``model`` on ``env`` (any VecEnv) until ``games`` episodes finished or ``steps`` env steps
    were taken (whichever is given and comes first); returns the finished games' statistics. The games are
    split evenly over the envs (:func:`game_quota`): an env past its share plays on uncounted.

    ``device``: where the model runs (default: its parameters' device). ``seed`` seeds the first
    ``reset``. ``on_game(index, reward, length, success)`` is called per finished game (success
    None when the env reports none); ``on_obs(obs, masks)`` with every observation batch the policy
    meets (and the one after the last step), with the action masks it acts under (None without).
    ``render_sleep`` renders each step. The model acts in eval mode (its mode restored after),
    with its distribution's mode when ``deterministic``. ``success_key`` / ``success_mode``: as the
    config keys.
    """
    if games is None and steps is None:
        raise ValueError("play needs games or steps")
    device = device if device is not None else next(model.parameters()).device
    rewards: list[float] = []
    episode_lengths: list[int] = []
    successes: list[float] = []
    success = EpisodeSuccess(env.num_envs, success_key, success_mode)
    quota = game_quota(games, env.num_envs)
    was_training = model.training
    model.eval()
    taken = 0
    try:
        loop = PolicySteps(model, env, device, deterministic, seed)
        returns = torch.zeros(env.num_envs, dtype=torch.float64)
        lengths = torch.zeros(env.num_envs, dtype=torch.long)
        while True:
            finished = (games is not None and len(rewards) >= games) or (steps is not None and taken >= steps)
            if finished and on_obs is None:
                break
            masks = loop.masks()
            if on_obs is not None:
                on_obs(loop.obs, masks)
            if finished:
                break
            result, done = loop.step(masks)
            taken += 1
            reward = torch.as_tensor(result.reward, dtype=torch.float64).cpu()
            reward = reward.sum(-1) if reward.dim() > 1 else reward
            lengths += 1
            success.step(result.infos, done.numpy())
            reward, game_over = game_outcome(result, reward, done)  # whole games (Atari lives)
            returns += reward
            for i in game_over.nonzero().flatten().tolist():
                won = success.pop(i)
                if quota is None or quota[i] > 0:
                    if quota is not None:
                        quota[i] -= 1
                    rewards.append(float(returns[i]))
                    episode_lengths.append(int(lengths[i]))
                    if won is not None:
                        successes.append(won)
                    if on_game is not None:
                        on_game(len(rewards), rewards[-1], episode_lengths[-1], won)
                returns[i], lengths[i] = 0.0, 0
            if render_sleep is not None:
                env.render()
                time.sleep(render_sleep)
    finally:
        model.train(was_training)
    n = len(rewards)
    return PlayResult(n, sum(rewards) / n if n else float("nan"), sum(episode_lengths) / n if n else float("nan"),
                      rewards, successes)


def act_policies(models: Any, plan: dict[str, list[str]], views: dict[str, Any], num_envs: int,
                 device: torch.device, deterministic: bool,
                 on_obs: Callable[[str, list[Any], np.ndarray, np.ndarray | None], None] | None = None,
                 seats: Seats | None = None, states: dict[str, tuple] | None = None) -> dict[str, np.ndarray]:
    """Each policy's actions for its agents: ``plan`` maps a policy to its agent ids, ``views`` an agent
    id to its view (``obs`` (num_envs, ...), ``mask``, ``active``); ``models[policy]`` acts on its agents'
    rows stacked agent by agent. ``on_obs(policy, its agents' views, obs, masks)`` sees each policy's
    stacked rows first. With ``seats``, an agent several policies may play takes, in each env, the action of
    the one that plays it there. ``states``: each recurrent policy's RNN states entering this step (replaced by
    the states after it)."""
    actions: dict[str, np.ndarray] = {}
    for name, agents in plan.items():
        model = models[name]
        obs = np.concatenate([views[a].obs for a in agents])
        masks = np.concatenate([views[a].mask for a in agents]) if model.use_action_masks else None
        if on_obs is not None:
            on_obs(name, [views[a] for a in agents], obs, masks)
        state = (states or {}).get(name) or None
        with torch.inference_mode():
            out = model.act(torch.as_tensor(obs, device=device), deterministic=deterministic, states=state,
                            action_masks=None if masks is None else torch.as_tensor(masks, device=device))
        if state is not None:
            states[name] = tuple(out["states"])
        acts = model.dist.to_env(out["actions"]).cpu().numpy()
        owned = seats.owned(name, agents) if seats is not None and seats.dynamic else None
        for k, a in enumerate(agents):
            mine = acts[k * num_envs:(k + 1) * num_envs]
            if owned is None:
                actions[a] = mine
            elif a not in actions:
                actions[a] = mine.copy()
            else:
                rows = owned[k * num_envs:(k + 1) * num_envs]
                actions[a][rows] = mine[rows]
    return actions


def step_policies(env: VecEnv, models: Any, plan: dict[str, list[str]], device: torch.device, deterministic: bool,
                  seed: int | None,
                  on_obs: Callable[[str, list[Any], np.ndarray, np.ndarray | None], None] | None = None,
                  seats: Seats | None = None) -> Iterator[Any]:
    """Reset ``env`` (a multi-agent VecEnv of views per agent) with ``seed``, then step it with every
    policy's actions (:func:`act_policies`) for as long as the caller iterates; yields each StepResult. With
    ``seats``, the policies of listed agents are chosen at each episode start, after the caller has read the
    step that ended the last one. A recurrent policy carries its RNN states from step to step, from zero at each
    episode start."""
    views = env.reset(seed=seed)
    if seats is not None:
        seats.draw(np.arange(env.num_envs), env.named_policies)
    states = {name: models[name].initial_state(len(agents) * env.num_envs, device) for name, agents in plan.items()}
    while True:
        result = env.step(act_policies(models, plan, views, env.num_envs, device, deterministic, on_obs, seats,
                                       states))
        yield result
        if seats is not None:
            seats.draw(result.started.nonzero()[0], env.named_policies)
        started = torch.as_tensor(result.started, device=device)
        for name, state in states.items():  # an RNN's rows of a new episode start from zero states
            if state:
                rows = started.repeat(len(plan[name])).view(1, -1, 1)
                states[name] = tuple(torch.where(rows, torch.zeros_like(s), s) for s in state)
        views = result.obs
