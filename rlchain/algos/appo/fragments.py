"""The runner side of appo / impala: a policy copy steps its own envs into fixed-length fragments.

:class:`FragmentRunner` is the body of one runner, the same in a local thread
(:mod:`rlchain.algos.appo.local_runners`) and in a Ray actor (:mod:`rlchain.algos.appo.ray_runners`):
it builds its envs from an :class:`~rlchain.envs.ray.ray_worker.EnvRecipe`, acts with a CPU copy of
the model (inference on the runner, as IMPALA does, so the learner never waits for a step), and
returns :class:`Fragment` s of ``horizon`` steps that carry the behaviour log-probs and the policy
version they were sampled with. Its envs run on between fragments (episodes span fragments).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from rlchain.algos.core.collector import CollectedStep, OnPolicyCollector, StepOutcome
from rlchain.envs.spec import EnvSpec, env_spec
from rlchain.envs.vecenv import VecEnv
from rlchain.envs.wrappers.info_means import InfoMeans
from rlchain.envs.wrappers.success import SuccessReader


class RunnerKilled(RuntimeError):
    """A runner was stopped in the middle of a fragment (its thread killed: tests, hung-runner cleanup)."""


@dataclass
class Fragment:
    """``horizon`` (T) steps of a runner's ``n`` envs, as CPU tensors.

    ``obs`` holds T + 1 rows: the last is the observation after the fragment (V-trace's bootstrap).
    ``final_steps`` (K, 2) are the (t, env) where an episode ended, ``final_obs`` (K, ...) the true
    last observation of each (a time-out bootstraps from it). ``episode_returns`` / ``episode_lengths``
    are the raw (unshaped) games finished in the fragment, for the episode statistics;
    ``episode_successes`` their task success where the env reported one (else None): (succeeded at
    any step, at the last step reported), the learner's ``success_mode`` picks one.
    """

    obs: torch.Tensor
    actions: torch.Tensor
    log_probs: torch.Tensor
    params: torch.Tensor
    rewards: torch.Tensor
    terminated: torch.Tensor
    truncated: torch.Tensor
    final_steps: torch.Tensor
    final_obs: torch.Tensor
    version: int
    worker: int
    episode_returns: list[float] = field(default_factory=list)
    episode_lengths: list[int] = field(default_factory=list)
    episode_successes: list[tuple[bool, bool] | None] = field(default_factory=list)
    states: tuple[torch.Tensor, ...] = ()
    """A recurrent policy's RNN states entering every step, each (T + 1, layers, n, units); () for a feed-forward
    one. Row T enters the observation after the fragment."""
    resets: torch.Tensor | None = None
    """A recurrent policy: (T + 1, n) bool, the rows whose observation starts an episode (their state was zeroed)."""
    final_states: tuple[torch.Tensor, ...] = ()
    """A recurrent policy: the RNN states after the last step of each ended episode, each (layers, K, units)."""
    info_totals: tuple | None = None
    """``log_info_keys``: (sums, counts, keys reported) over the fragment's steps (InfoMeans.totals)."""
    sample_seconds: float = 0.0

    @property
    def frames(self) -> int:
        return int(self.log_probs.numel())


class FragmentRunner:
    """One runner: envs ``[start, start + num_envs)`` of the batch and a CPU policy copy.

    ``step_delay_s`` adds a sleep to every env step (benchmarks and tests make stragglers with it).
    ``kill()`` makes the fragment in progress stop with :class:`RunnerKilled`.
    """

    def __init__(self, recipe: Any, worker: int, start: int, num_envs: int, horizon: int,
                 step_delay_s: float = 0.0) -> None:
        self.recipe, self.worker, self.start, self.num_envs, self.horizon = recipe, worker, start, num_envs, horizon
        self.step_delay_s = step_delay_s
        self.env: VecEnv | None = None
        self.model: torch.nn.Module | None = None
        self.version = -1
        self._seed: int | None = None
        self._killed = threading.Event()
        self.fragments_sampled = 0
        self._returns = np.zeros(num_envs)
        self._lengths = np.zeros(num_envs, dtype=np.int64)
        self._success = SuccessReader(getattr(recipe, "success_key", "auto"))
        self._success_flags = np.zeros((3, num_envs), dtype=bool)  # reported, hit at any step, hit at the last
        self._info_means = InfoMeans(getattr(recipe, "log_info_keys", ()))
        self._steps_collector: OnPolicyCollector | None = None
        self._steps: dict[str, list] = {}

    # ----- setup ----------------------------------------------------------------------------
    def build(self, seed: int | None, own_process: bool = False) -> dict:
        """Make the envs; returns their spaces and value size. ``own_process`` (a Ray actor): one torch
        thread, as many runners share the cores (a thread runner leaves the process's setting alone)."""
        if own_process:
            torch.set_num_threads(1)
        try:
            self.env = self.recipe.build(self.num_envs, seed)
        except ValueError as exc:  # config errors travel as plain ValueErrors (picklable, one line)
            raise ValueError(str(exc)) from None
        self._seed = seed
        return {"observation_space": self.env.observation_space, "action_space": self.env.action_space,
                "value_size": env_spec(self.env).value_size}

    def start(self, seed: int | None, own_process: bool, model: torch.nn.Module, weights: dict,
              version: int) -> int:
        """:meth:`build` then :meth:`set_policy` in one call (a replacement Ray actor); returns ``version``."""
        self.build(seed, own_process)
        self.set_policy(model, weights, version)
        return version

    def set_policy(self, model: torch.nn.Module, weights: dict | None = None, version: int = 0) -> None:
        """The model this runner acts with (a CPU copy, evaluation mode), and its weights."""
        self.model = model.to("cpu").eval()
        if weights is not None:
            self.load_weights(weights, version)

    def load_weights(self, weights: dict, version: int) -> None:
        """New policy weights (and normalizer statistics) of learner version ``version``."""
        self.model.load_state_dict(weights)
        self.version = version

    def kill(self) -> None:
        self._killed.set()

    @property
    def killed(self) -> bool:
        return self._killed.is_set()

    def pid(self) -> int:
        import os
        return os.getpid()

    # ----- sampling -------------------------------------------------------------------------
    def sample(self, weights: dict | None = None, version: int | None = None) -> Fragment:
        """``horizon`` steps of every env with the current policy (new ``weights`` first, when given), stepped
        by the on-policy collector with this runner's own bookkeeping (:class:`RunnerSide`)."""
        if weights is not None:
            self.load_weights(weights, version)
        began = time.monotonic()
        collector = self._collector()  # where this runner's envs stand
        if collector.obs is None:
            collector.place(torch.as_tensor(np.asarray(self.env.reset(seed=self._seed))))
        steps = self._steps = {"obs": [], "actions": [], "log_probs": [], "params": [], "rewards": [],
                               "terminated": [], "truncated": [], "final_steps": [], "final_obs": [],
                               "states": [], "resets": [], "final_states": [],
                               "returns": [], "lengths": [], "successes": []}
        version = self.version
        if not collector.rollout():
            raise RunnerKilled(f"runner {self.worker} killed")
        obs = collector.obs
        steps["obs"].append(obs)
        self.fragments_sampled += 1
        empty_final = torch.zeros((0, *obs.shape[1:]), dtype=obs.dtype)
        final_obs = steps["final_obs"]
        recurrent = bool(collector.rnn_states)
        if recurrent:  # the row after the fragment: where the next one starts
            steps["states"].append(collector.rnn_states)
            steps["resets"].append(collector.resets)
        return Fragment(
            obs=torch.stack(steps["obs"]), actions=torch.stack(steps["actions"]),
            log_probs=torch.stack(steps["log_probs"]), params=torch.stack(steps["params"]),
            rewards=torch.stack(steps["rewards"]), terminated=torch.stack(steps["terminated"]),
            truncated=torch.stack(steps["truncated"]),
            final_steps=torch.tensor(steps["final_steps"], dtype=torch.long).reshape(-1, 2),
            final_obs=torch.cat(final_obs).to(obs.dtype) if final_obs else empty_final,
            version=version, worker=self.worker, episode_returns=steps["returns"], episode_lengths=steps["lengths"],
            episode_successes=steps["successes"],
            states=tuple(torch.stack(s) for s in zip(*steps["states"])),
            resets=torch.stack(steps["resets"]) if recurrent else None,
            final_states=tuple(torch.cat(s, dim=1) for s in zip(*steps["final_states"])) if recurrent else (),
            info_totals=self._info_means.totals() if self._info_means.keys else None,
            sample_seconds=time.monotonic() - began)

    def _collector(self) -> OnPolicyCollector:
        """The collector over this runner's envs and policy copy (rebuilt when either changed: the same envs keep
        their place, new envs start from a reset)."""
        c = self._steps_collector
        if c is None or c.env is not self.env or c.model is not self.model:
            side = RunnerSide(self)
            same_envs = c is not None and c.env is self.env
            new = self._steps_collector = OnPolicyCollector(self.env, self.model, side, None, horizon=self.horizon,
                                                            on_step=self._on_step, carries_states=True)
            if same_envs:  # a recurrent policy's memory stays with its envs' episodes
                new.place(c.obs, c.rnn_states or None, c.resets)
            c = new
        return c

    def _on_step(self, step: CollectedStep) -> None:
        """A fragment row: what the policy saw and did, the env's answer, the true last observations of the
        episodes that ended."""
        steps, out = self._steps, step.out
        rewards, terminated, truncated, dones = step.outcome
        collector = self._steps_collector
        if collector.rnn_states:  # a recurrent policy: the states that entered this step (not yet moved on)
            steps["states"].append(collector.rnn_states)
            steps["resets"].append(collector.resets)
        steps["obs"].append(step.obs)
        steps["actions"].append(out["actions"])
        steps["log_probs"].append(out["log_probs"])
        steps["params"].append(out["params"])
        steps["rewards"].append(rewards)
        steps["terminated"].append(terminated)
        steps["truncated"].append(truncated)
        rows = np.flatnonzero(dones.numpy())
        if rows.size:
            steps["final_steps"].extend((step.t, int(r)) for r in rows)
            steps["final_obs"].append(torch.as_tensor(np.asarray(step.result.final_obs)[rows]))
            if out["states"]:  # the states after the episode's last step, before they were zeroed
                index = torch.as_tensor(rows)
                steps["final_states"].append(tuple(s.index_select(1, index) for s in out["states"]))

    def record(self, result: Any) -> StepOutcome:
        """An env step's outcome for the runner: ``step_delay_s`` first (a straggler), then the episodes'
        returns, lengths and success and the info means; (rewards, terminated, truncated, dones) as CPU tensors."""
        if self.step_delay_s and self._killed.wait(self.step_delay_s):
            raise RunnerKilled(f"runner {self.worker} killed")
        reward = np.asarray(result.reward, dtype=np.float32)
        term, trunc = np.asarray(result.terminated, dtype=bool), np.asarray(result.truncated, dtype=bool)
        done = term | trunc
        steps = self._steps
        self._track(result, reward, done, steps["returns"], steps["lengths"], steps["successes"])
        if self._info_means.keys:
            self._info_means.add(getattr(result, "infos", None))
        return StepOutcome(torch.as_tensor(reward), torch.as_tensor(term), torch.as_tensor(trunc),
                           torch.as_tensor(done))

    def _track(self, result: Any, reward: np.ndarray, done: np.ndarray, returns: list, lengths: list,
               successes: list) -> None:
        """Raw episode returns and lengths (whole games when the env reports game_reward / game_over),
        and the episodes' task success from the step infos (:mod:`rlchain.envs.wrappers.success`)."""
        seen, hit_any, hit_last = self._success_flags
        success = self._success.read(getattr(result, "infos", None), done)
        if success is not None:
            reported = ~np.isnan(success)
            hit = reported & (success > 0.5)
            seen |= reported
            hit_any |= hit
            hit_last[reported] = hit[reported]
        game_reward = getattr(result, "game_reward", None)
        game_over = getattr(result, "game_over", None)
        reward = np.asarray(game_reward, dtype=np.float64).reshape(-1) if game_reward is not None else reward
        if reward.ndim > 1:
            reward = reward.sum(-1)
        over = np.asarray(game_over, dtype=bool).reshape(-1) if game_over is not None else done
        self._returns += reward
        self._lengths += 1
        for i in np.flatnonzero(over):
            returns.append(float(self._returns[i]))
            lengths.append(int(self._lengths[i]))
            successes.append((bool(hit_any[i]), bool(hit_last[i])) if seen[i] else None)
            self._returns[i], self._lengths[i] = 0.0, 0
            self._success_flags[:, i] = False

    def close(self) -> None:
        if self.env is not None:
            self.env.close()
            self.env = None


class RunnerSide:
    """What the on-policy collector asks of its run, on a runner: no RunContext there (the learner's is in
    another thread or process), so the runner answers: CPU tensors, its own episode
    bookkeeping (:meth:`FragmentRunner.record`), a kill as the stop signal; actions in the form the runner's env
    takes (its spec's ``to_env``)."""

    device = torch.device("cpu")
    epoch = 0

    def __init__(self, runner: FragmentRunner) -> None:
        self.runner = runner
        self.spec: EnvSpec = env_spec(runner.env)

    def stop_requested(self) -> bool:
        return self.runner.killed

    def to_tensor(self, x: Any) -> torch.Tensor:
        return torch.as_tensor(np.asarray(x))

    def record_step(self, result: Any, rows: slice) -> StepOutcome:
        return self.runner.record(result)
