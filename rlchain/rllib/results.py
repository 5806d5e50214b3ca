"""RLlib's result dict of one ``train()`` built from rlchain's epoch report (the face's Algorithm calls it):
``env_runners/...``, ``learners/<module>/...``, the counters and timings, and the older top-level names."""

from __future__ import annotations

import math
import time
from typing import Any

from rlchain.rllib.callbacks.callbacks import nested
from rlchain.rllib.core import ALL_MODULES, DEFAULT_MODULE_ID
from rlchain.rllib.off_policy_results import FRAMES, live_learning_rates

LAST = "last_minibatch/"
"""Prefix of the update's last minibatch's statistics among the epoch statistics the face reads
(:func:`with_last_minibatch`)."""


def with_last_minibatch(stats: dict[str, Any], agent: Any) -> dict[str, Any]:
    """rlchain's epoch ``stats`` with ``agent``'s last minibatch's statistics added under :data:`LAST` (the PPO
    agent's ``last_minibatch_stats``; none for an agent without them)."""
    last = getattr(agent, "last_minibatch_stats", None) or {}
    return {**stats, **{LAST + key: value for key, value in last.items()}}


def learner_inputs(stats: dict[str, Any], agent: Any, frames: int) -> dict[str, Any]:
    """The statistics the face's ``learner_results`` read: rlchain's epoch ``stats`` with the last minibatch's
    (:func:`with_last_minibatch`), the env steps sampled so far and each optimizer's live learning rate
    (:mod:`rlchain.rllib.off_policy_results`)."""
    return {**with_last_minibatch(stats, agent), FRAMES: int(frames), **live_learning_rates(agent)}


def last_minibatch_by_policy(agent: Any) -> dict[str, dict[str, float]]:
    """Each multi-agent policy's last minibatch's statistics (rlchain's multi-policy ``PolicyAgents``: one PPO
    agent per trained policy)."""
    agents = getattr(agent, "agents", None) or {}
    return {pid: dict(getattr(a, "last_minibatch_stats", None) or {}) for pid, a in agents.items()}


def learner_results(stats: dict[str, Any]) -> dict[str, Any]:
    """RLlib's ``learners/<module>`` results from rlchain's epoch statistics (PPO's, APPO's, IMPALA's names).

    RLlib 2.60's PPO, APPO and IMPALA learners log ``policy_loss``, ``vf_loss``, ``entropy``, ``mean_kl_loss`` and
    the gradients' global norm once per minibatch with ``window=1``: a result holds the iteration's last
    minibatch's values, not a mean; so does the face's, from the agent's last minibatch (the epoch's means where
    there is none). ``total_loss`` is that minibatch's whole loss (policy loss + vf_loss_coeff * vf loss -
    entropy_coeff * entropy + kl_coeff * KL, RLlib's sum; NaN without a last minibatch). ``curr_lr`` /
    ``curr_entropy_coeff``: the values rlchain trained with (a schedule's next value replaces them:
    :func:`scheduled_results`)."""
    nan = math.nan

    def last(key: str) -> Any:
        return stats.get(LAST + key, stats.get(key, nan))

    return {"policy_loss": last("a_loss"), "vf_loss": last("c_loss"), "entropy": last("entropy"),
            "mean_kl_loss": last("kl"), "total_loss": last("loss"), "curr_lr": stats.get("lr", nan),
            "curr_entropy_coeff": stats.get("entropy_coef", 0.0),
            "gradients_default_optimizer_global_norm": last("grad_norm")}


SCHEDULED_RESULTS = {"learning_rate": "curr_lr", "entropy_coef": "curr_entropy_coeff"}
"""The learner result of each parameter the face schedules (:mod:`rlchain.rllib.schedules`)."""


def scheduled_results(values: dict[str, float]) -> dict[str, float]:
    """The learner results of scheduled ``values`` (rlchain's parameter -> value).

    RLlib's Learner steps its schedulers after each update, at the env steps sampled so far (this iteration's
    included), and logs the new learning rate and entropy coefficient: a result reports the value the next
    ``train()`` updates with. The face sets that value before the next ``train()`` and reports it the same way."""
    return {SCHEDULED_RESULTS[param]: value for param, value in values.items() if param in SCHEDULED_RESULTS}


def with_lr_key(learner: dict[str, Any]) -> dict[str, Any]:
    """RLlib 2.60 reports a module's learning rate as ``default_optimizer_learning_rate`` (``curr_lr`` is the older
    name, kept): both, where the learner results have one."""
    if "curr_lr" in learner and "default_optimizer_learning_rate" not in learner:
        return {**learner, "default_optimizer_learning_rate": learner["curr_lr"]}
    return learner


EPISODE_KEYS = ("episode_return_mean", "episode_len_mean", "episode_return_min", "episode_return_max",
                "agent_episode_returns_mean", "module_episode_returns_mean")
"""The ``env_runners`` episode results RLlib 2.60 leaves out until the run's first episode ended (then NaN in an
iteration that ended none)."""


def train_result(report: Any, cfg: dict[str, Any], *, iteration: int, time_total: float, games: int,
                 episode_custom: dict[str, Any], learner: dict[str, Any], multi: Any = None,
                 episodes: dict[str, float] | None = None,
                 last_by_policy: dict[str, dict[str, float]] | None = None) -> dict[str, Any]:
    """One ``train()``'s result: ``report`` is rlchain's epoch report, ``cfg`` the run's ``params.config``,
    ``episodes`` RLlib's episode results of this iteration (:func:`rlchain.rllib.episode_window.iteration_metrics`;
    None: the epoch report's means over rlchain's last ``games_to_track`` episodes),
    ``learner`` the default module's learner results, ``multi`` the multi-agent run (its episodes summed over
    agents and one learner per policy) or None, ``last_by_policy`` its policies' last minibatches
    (:func:`last_minibatch_by_policy`). ``_episode_custom`` carries the episode callbacks' values (the
    Algorithm writes and removes it)."""
    nan = math.nan
    ret = nan if report.mean_reward is None else report.mean_reward
    length = nan if report.mean_length is None else report.mean_length
    frames = int(report.frames)
    per_iter = int(cfg["num_actors"] * cfg.get("horizon_length", cfg.get("num_steps_per_episode", 1)))
    if episodes is not None:
        ret, length = episodes["episode_return_mean"], episodes["episode_len_mean"]
    env_runners = {**(episodes or {}), "episode_return_mean": ret, "episode_len_mean": length,
                   "num_env_steps_sampled": per_iter, "num_env_steps_sampled_lifetime": frames,
                   "num_episodes_lifetime": games, **nested(episode_custom)}
    learner = dict(learner)  # an algorithm's own counters over all modules replace the default (DQN's, SAC's)
    all_modules = learner.pop(ALL_MODULES, None) or {"num_env_steps_trained": per_iter}
    if "kl_coef" in report.stats:
        learner = {**learner, "curr_kl_coeff": report.stats["kl_coef"]}
    learners = {DEFAULT_MODULE_ID: learner}
    if multi is not None:  # RLlib's multi-agent episodes (returns summed over agents), one learner a policy
        env_runners.update(multi.episodes())
        ret, length = env_runners["episode_return_mean"], env_runners["episode_len_mean"]
        learners = multi.learners(report.stats, cfg["learning_rate"], last_by_policy)
    if not env_runners.get("num_episodes_lifetime"):  # RLlib 2.60 has no episode means before an episode ended
        for key in EPISODE_KEYS:
            env_runners.pop(key, None)
    return {
        "training_iteration": iteration, "iterations_since_restore": iteration,
        "time_this_iter_s": report.seconds, "time_total_s": time_total, "timestamp": int(time.time()),
        "num_env_steps_sampled_lifetime": frames, "timesteps_total": frames,
        "num_training_step_calls_per_iteration": 1, "done": False,
        "env_runners": env_runners,
        "learners": {**{k: with_lr_key(v) for k, v in learners.items()},
                     ALL_MODULES: all_modules},
        "episode_reward_mean": ret, "episode_return_mean": ret, "episode_len_mean": length,
        "info": {"learner": {k: {"learner_stats": dict(v)} for k, v in learners.items()}},
        "_episode_custom": episode_custom,
    }


def deep_update(into: dict[str, Any], new: dict[str, Any]) -> None:
    """``into`` updated in place with ``new``, nested dicts merged key by key."""
    for key, value in new.items():
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            deep_update(into[key], value)
        else:
            into[key] = value
