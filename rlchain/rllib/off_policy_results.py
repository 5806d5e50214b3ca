"""RLlib 2.60's ``learners/<module>`` results of DQN and SAC from rlchain's off-policy epoch statistics.

What RLlib's results hold after one ``train()`` (its DQN / SAC torch learners and ``MetricsLogger``): each
gradient step logs its losses and Q statistics with ``window=1``, one value per ``LearnerGroup.update()``;
DQN's ``training_step`` (SAC's too) calls ``update()`` once per gradient step, and the Algorithm's root logger
merges those values unwindowed and reduces them with a mean: a result holds the mean over the iteration's
gradient steps (not the last step's, as PPO's one ``update()`` of many minibatches does). rlchain's off-policy
epoch statistics are that mean already (:meth:`rlchain.algos.off_policy.off_policy.OffPolicyAlgorithm.update`);
this module names them as RLlib does and adds RLlib's counters: ``num_env_steps_trained`` (the train batch
times the gradient steps), its ``_lifetime`` sum, ``num_target_updates`` (a lifetime count) and
``last_target_update_ts`` (the env steps sampled when the target network last moved).
"""

from __future__ import annotations

import math
from typing import Any

from rlchain.rllib.core import ALL_MODULES  # a learner result carrying it replaces the face's default counters

FRAMES = "face/frames"
"""The env steps sampled so far, among the statistics the face passes to ``learner_results``."""

LR = "face/lr/"
"""Prefix of each optimizer's live learning rate (rlchain's name: ``actor_lr``, ``critic_lr``, ...)."""


def live_learning_rates(agent: Any) -> dict[str, float]:
    """Each of ``agent``'s optimizers' learning rate under :data:`LR` + rlchain's name (none for an agent
    without ``optimizers()``)."""
    optimizers = getattr(agent, "optimizers", None)
    if optimizers is None:
        return {}
    return {LR + name: float(opt.param_groups[0]["lr"]) for name, opt in optimizers().items()}


def trained_counters(stats: dict[str, Any], batch_size: int) -> tuple[dict[str, float], dict[str, float]]:
    """(the module's, all modules') trained-steps counters: RLlib counts each gradient step's train batch."""
    now = int(stats.get("updates", 0)) * batch_size
    lifetime = int(stats.get("total_updates", 0)) * batch_size
    module = {"module_train_batch_size_mean": float(batch_size), "num_module_steps_trained": now,
              "num_module_steps_trained_lifetime": lifetime}
    return module, {"num_env_steps_trained": now, "num_env_steps_trained_lifetime": lifetime,
                    "num_module_steps_trained": now, "num_module_steps_trained_lifetime": lifetime}


def last_target_update_frames(total_updates: int, epoch_updates: int, every: int, updates_per_step: int,
                              frames: int, num_envs: int, update_every: int = 1) -> int | None:
    """The env steps sampled when the target network last moved, if it moved in this epoch (None if not).

    rlchain's off-policy epoch makes ``updates_per_step`` gradient steps after every ``update_every``-th
    vectorized env step of the run (``num_envs`` env steps each) once learning has started, the epoch ending at
    ``frames``; the target moves on every ``every``-th gradient step of the run (``total_updates`` so far,
    ``epoch_updates`` of them in this epoch)."""
    last = total_updates // every * every
    first_this_epoch = total_updates - epoch_updates + 1
    if last < max(first_this_epoch, 1):
        return None
    stride = update_every * num_envs  # env steps from one update round to the next
    rounds_after = (total_updates - last) // updates_per_step  # update rounds after the one that moved it
    return frames // stride * stride - rounds_after * stride


class TargetUpdates:
    """RLlib's ``num_target_updates`` and ``last_target_update_ts`` (the last kept across iterations, as RLlib's
    ``reduce="max"`` keeps it); none before the first target update, as in RLlib."""

    def __init__(self) -> None:
        self.last_ts: int | None = None

    def results(self, stats: dict[str, Any], every: int, updates_per_step: int, num_envs: int,
                update_every: int = 1) -> dict[str, float]:
        total, now = int(stats.get("total_updates", 0)), int(stats.get("updates", 0))
        ts = last_target_update_frames(total, now, every, updates_per_step, int(stats.get(FRAMES, 0)), num_envs,
                                       update_every)
        if ts is not None:
            self.last_ts = ts
        if total // every == 0:
            return {}
        out = {"num_target_updates": float(total // every)}
        if self.last_ts is not None:
            out["last_target_update_ts"] = float(self.last_ts)
        return out


def dqn_results(stats: dict[str, Any], cfg: dict[str, Any], targets: TargetUpdates) -> dict[str, Any]:
    """RLlib 2.60's DQN learner results (``total_loss`` is ``qf_loss``: DQN's loss is its TD loss alone).
    ``curr_lr`` is the older learning-rate name (``default_optimizer_learning_rate`` is added from it);
    ``curr_epsilon`` is the face's own: RLlib 2.60 logs no epsilon."""
    nan = math.nan
    batch = int(cfg["batch_size"])
    module, every = trained_counters(stats, batch)
    loss = stats.get("td_loss", nan)
    return {"qf_loss": loss, "total_loss": loss, "qf_mean": stats.get("q", nan), "qf_max": stats.get("q_max", nan),
            "qf_min": stats.get("q_min", nan), "td_error_mean": stats.get("td_error", nan),
            "curr_epsilon": stats.get("epsilon", nan),
            "curr_lr": stats.get(LR + "learning_rate", stats.get("lr", cfg["learning_rate"])), **module,
            **targets.results(stats, int(cfg["target_update_frequency"]), int(cfg["num_updates_per_step"]),
                              int(cfg["num_actors"]), int(cfg.get("update_every", 1))),
            ALL_MODULES: every}


def sac_results(stats: dict[str, Any], cfg: dict[str, Any], targets: TargetUpdates) -> dict[str, Any]:
    """RLlib 2.60's SAC learner results: ``qf_loss`` the first critic's loss and ``qf_twin_loss`` the second's
    (rlchain's ``critic_loss`` is their sum), ``qf_mean`` / ``qf_max`` / ``qf_min`` the twin critics' minimum at
    the policy's actions, ``logps`` their mean log-probability, ``alpha_value`` the temperature each step used,
    one learning rate per optimizer (``policy_``, ``qf_``, ``qf_twin_``, ``alpha_learning_rate``); the target
    critics move after every gradient step (RLlib's ``target_network_update_freq`` 0)."""
    nan = math.nan
    module, every = trained_counters(stats, int(cfg["batch_size"]))
    critic, first = stats.get("critic_loss", nan), stats.get("critic1_loss", nan)
    actor, alpha_loss = stats.get("actor_loss", nan), stats.get("alpha_loss", nan)
    entropy = stats.get("entropy", nan)
    critic_lr = stats.get(LR + "critic_lr", cfg["critic_lr"])
    return {"qf_loss": first, "qf_twin_loss": critic - first, "policy_loss": actor, "alpha_loss": alpha_loss,
            "total_loss": actor + critic + alpha_loss, "alpha_value": stats.get("alpha_used", nan),
            "log_alpha_value": stats.get("log_alpha", nan), "target_entropy": stats.get("target_entropy", nan),
            "logps": -entropy, "qf_mean": stats.get("q_pi", nan), "qf_max": stats.get("q_pi_max", nan),
            "qf_min": stats.get("q_pi_min", nan), "td_error_mean": stats.get("td_error", nan),
            "policy_learning_rate": stats.get(LR + "actor_lr", stats.get("lr", cfg["actor_lr"])),
            "qf_learning_rate": critic_lr, "qf_twin_learning_rate": critic_lr,
            "alpha_learning_rate": stats.get(LR + "alpha_lr", cfg["alpha_lr"]), **module,
            **targets.results(stats, 1, int(cfg["num_updates_per_step"]), int(cfg["num_actors"]),
                              int(cfg.get("update_every", 1))),
            ALL_MODULES: every}
