"""Keys of the actor-critic algorithms that train with the PPO agent: PPO (``a2c_continuous`` /
``a2c_discrete``), ``appo`` and ``impala``.

They share the agent's optimizer, learning-rate schedules, value and entropy losses, normalizers and
minibatches, so these keys mean the same for the three; each algorithm's class adds its own keys
(:class:`~rlchain.config.ppo.PPOConfig`, :class:`~rlchain.config.appo.APPOConfig`,
:class:`~rlchain.config.appo.ImpalaConfig`).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass

from rlchain.config import compat
from rlchain.config.errors import ConfigError
from rlchain.config.fields import above_one, non_negative, option, positive
from rlchain.config.run import RunConfig


@dataclass(frozen=True)
class ActorCriticConfig(RunConfig):
    """``params.config`` keys every algorithm trained by the PPO agent reads (PPO, appo, impala)."""

    horizon_length: int = option(32, "steps per env per epoch; batch = num_actors * horizon_length * "
                                     "agents per env", check=positive)
    minibatch_size: int | None = option(None, "minibatch size; the batch must divide by it (this or "
                                              "minibatch_size_per_env is required)", check=positive)
    minibatch_size_per_env: int | None = option(None, "minibatch = num_actors * this", check=positive)
    minibatch_order: str = option("auto", "which steps each minibatch holds. fixed = rl_games' order: the "
                                          "rollout flattened env by env and cut in turn, so minibatch k is the "
                                          "same whole env trajectories (whole sequences for an RNN) in every "
                                          "mini-epoch; shuffle = a new random permutation every mini-epoch; "
                                          "auto = fixed for continuous actions (measured better on the MuJoCo "
                                          "YAMLs, docs/ppo_parity.md), shuffle otherwise; rllib = RLlib's "
                                          "MiniBatchCyclicIterator over its train batch (each env's steps in "
                                          "time order with one masked row after every episode chunk; "
                                          "minibatch_size rows at a time cycling across passes, the first pass "
                                          "in order, a reshuffle at each wrap, until every row was covered "
                                          "mini_epochs times; the masked rows are left out of each minibatch, "
                                          "so sizes vary and the batch need not divide by minibatch_size; an "
                                          "RNN or a central value: shuffle)",
                                  choices=("auto", "fixed", "shuffle", "rllib"))
    learning_rate: float = option(3e-4, "Adam learning rate", check=positive)
    lr_schedule: str | None = option(None, "None (constant), linear, adaptive (KL-based) or polynom_decay "
                                           "(min_lr + (learning_rate - min_lr) * (1 - progress) ** decay_power; "
                                           "progress = epochs/max_epochs, else frames/max_frames)",
                                     choices=("linear", "adaptive", "constant", "polynom_decay"))
    kl_threshold: float = option(0.008, "adaptive schedule target KL", check=positive)
    schedule_type: str = option("legacy", "adaptive: legacy = after every minibatch, standard = "
                                          "after every mini-epoch", choices=("legacy", "standard"))
    kl_reference: str = option("auto", "adaptive: the policy the KL compares the current one with. previous = each "
                                       "sample's policy at its previous minibatch (the rollout's on the first "
                                       "pass), as rl_games' continuous agent; rollout = the policy that collected "
                                       "the batch, as rl_games' discrete agent; auto = previous for continuous "
                                       "actions, rollout otherwise. The logged kl is this one",
                               choices=("auto", "previous", "rollout"))
    min_lr: float = option(1e-6, "adaptive / linear / polynom_decay schedule floor", check=non_negative)
    max_lr: float = option(1e-2, "adaptive schedule ceiling", check=positive)
    lr_multiplier: float = option(1.5, "adaptive: the lr is divided / multiplied by this when the KL is above "
                                       "2 * kl_threshold / below kl_threshold / 2 (rl_games 2.0's key)",
                                  check=above_one)
    decay_power: float = option(1.0, "polynom_decay: the exponent (1 = linear; rl_games' TensorFlow agent's key; "
                                     "its torch agent keeps a polynom_decay lr constant)", check=positive)
    critic_coef: float = option(1.0, "critic loss weight: loss += critic_coef * 0.5 * value loss",
                                check=non_negative)
    entropy_coef: float = option(0.0, "entropy bonus weight")
    schedule_entropy: bool = option(False, "with lr_schedule linear: the entropy bonus weight moves linearly from "
                                           "entropy_coef to 1e-4 alongside the lr (logged as info/entropy_coef); "
                                           "no effect with another lr_schedule (a warning), as in rl_games")
    normalize_advantage: bool = option(True, "normalize advantages over the whole batch")
    advantage_normalization: str = option("batch", "rlchain, with normalize_advantage: batch = over the whole "
                                                   "batch once (rl_games); minibatch = over each minibatch "
                                                   "(Stable-Baselines3); rllib = over the batch and RLlib's "
                                                   "bootstrap rows (one per episode chunk, advantage "
                                                   "gamma * (V + lambda * A) of the next chunk's first step minus "
                                                   "V(final obs)), population std floored at 1e-4 (RLlib's GAE "
                                                   "connector)", choices=("batch", "minibatch", "rllib"))
    normalize_value: bool = option(False, "running mean/std normalization of value targets (value_normalizer "
                                          "says which statistics)")
    value_normalizer: str = option("rl_games", "with normalize_value: rl_games = statistics of the rollout's value "
                                               "predictions and its returns, normalized values and the value "
                                               "head's output clipped to +-5 (rl_games' value_mean_std; Hopper "
                                               "learns faster per frame, docs/ppo_parity.md); returns = "
                                               "statistics of the returns only, no clip",
                                   choices=("rl_games", "returns"))
    obs_normalizer: str = option("rl_games", "with normalize_input (and central_value_config.normalize_input): "
                                             "rl_games = (x - mean) / sqrt(var + 1e-5) clipped to +-5; rsl_rl = "
                                             "rsl_rl's empirical normalization, (x - mean) / (std + 1e-2), no clip, "
                                             "folded in at every env step (obs_normalizer_update auto)",
                                 choices=("rl_games", "rsl_rl"))
    obs_normalizer_exclude: list[str] = option([], "rlchain, Dict observations kept per key: keys normalize_input "
                                                   "leaves as they are (uint8 images are only scaled to [0, 1] "
                                                   "anyway; every other key gets its own running mean/std)",
                                               check=lambda keys: None if all(isinstance(k, str) and k for k in keys)
                                               else "expected a list of observation key names")
    normalize_rms_advantage: bool = option(False, "with normalize_advantage: normalize by moving averages of the "
                                                  "advantages' mean and square (rl_games 2.0) instead of the batch's")
    adv_rms_momentum: float = option(0.5, "with normalize_rms_advantage: the moving averages' decay per epoch",
                                     check=lambda m: None if 0.0 <= m < 1.0 else "expected 0 <= adv_rms_momentum < 1")
    freeze_critic: bool = option(False, "train the actor only", status="planned")
    epochs_between_resets: int = option(0, "reset all envs every N epochs", status="planned")
    value_bootstrap: bool = option(True, "on time-out bootstrap V(true final obs) instead of a terminal")
    grad_norm: float = option(1.0, "max gradient norm when truncate_grads", check=positive)
    truncate_grads: bool = option(False, "clip gradients to grad_norm")
    weight_decay: float = option(0.0, "Adam weight decay", check=non_negative)
    bounds_loss_coef: float | None = option(None, "continuous: weight of the bounds loss (None = off)",
                                            check=non_negative)
    bound_loss_type: str = option("bound", "bound (mean beyond +-1.1) or regularisation (sum mu^2)",
                                  choices=("bound", "regularisation"))
    use_diagnostics: bool = option(False, "extra TensorBoard diagnostics (clip fraction, explained variance)")
    value_size: int | None = option(None, "value outputs (normally from the env)", status="planned")

    def resolved(self, source: str) -> ActorCriticConfig:
        """Cross-key checks that no single field can make; returns the config with the derived values
        filled in (minibatch_size from minibatch_size_per_env, lr_schedule constant -> None)."""
        config = self
        if config.minibatch_size_per_env is not None:
            if config.minibatch_size is not None:
                raise ConfigError(source, "params.config.minibatch_size_per_env",
                                  "give minibatch_size or minibatch_size_per_env, not both")
            config = dataclasses.replace(config, minibatch_size=config.num_actors * config.minibatch_size_per_env)
        if config.minibatch_size is None:
            raise ConfigError(source, "params.config.minibatch_size",
                              "required key is missing (or give minibatch_size_per_env)")
        # minibatch_size must divide num_actors * horizon_length * agents per env; the agent count is known
        # once the env is built, so that check runs then (check_batch, before any run folder exists)
        if not config.env_name:
            raise ConfigError(source, "params.config.env_name", "required key is missing")
        if config.lr_schedule == "constant":
            config = dataclasses.replace(config, lr_schedule=None)
        config._check_schedules(source)
        config._check_rollout_size(source)
        return config

    def _check_rollout_size(self, source: str) -> None:
        """Before any env is built: a rollout that cannot fit this machine's memory even at its smallest
        (num_actors or horizon_length far too large) is an error; the exact size is checked once the env's
        spaces are known (the algorithm's check_config)."""
        try:
            total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (OSError, ValueError, AttributeError):
            return
        least = self.num_actors * self.horizon_length * ROLLOUT_MIN_BYTES
        if least > total:
            key = "horizon_length" if self.horizon_length >= self.num_actors else "num_actors"
            raise ConfigError(source, f"params.config.{key}", f"num_actors {self.num_actors} x horizon_length "
                              f"{self.horizon_length} needs at least {least / 2**30:.0f} GiB for the rollout, "
                              f"this machine has {total / 2**30:.0f} GiB of memory")

    def _check_schedules(self, source: str) -> None:
        """polynom_decay needs a horizon to decay over; keys that only act with another schedule warn."""
        if self.lr_schedule == "polynom_decay" and self.max_epochs <= 0 and self.max_frames <= 0:
            raise ConfigError(source, "params.config.lr_schedule", "polynom_decay decays over the run: set "
                              "max_epochs or max_frames")
        if self.schedule_entropy and self.lr_schedule != "linear":
            compat.warn_once(source, "params.config.schedule_entropy", f"True has no effect with lr_schedule "
                             f"{self.lr_schedule or 'None'}: as in rl_games the entropy schedule runs with "
                             f"lr_schedule linear only; entropy_coef stays {self.entropy_coef}")
        if self.decay_power != 1.0 and self.lr_schedule != "polynom_decay":
            compat.warn_once(source, "params.config.decay_power", f"no effect with lr_schedule "
                             f"{self.lr_schedule or 'None'}; it is the exponent of polynom_decay")


ROLLOUT_MIN_BYTES = 16  # the least one step of one env takes in the rollout storage (an observation, an action)


def check_batch(config: ActorCriticConfig, source: str, agents: int = 1) -> None:
    """The one check that a minibatch divides the batch num_actors * horizon_length * ``agents`` (agents per env):
    ``minibatch_size``, and the central value's (``central_value_config.minibatch_size``) when there is one.

    At load time the env is unknown, so the algorithm runs this once the env is built (its
    ``check_config``), with its agent count, before a run folder is created.
    """
    batch = config.num_actors * config.horizon_length * agents
    what = "num_actors*horizon_length" + (f"*agents ({agents} per env)" if agents > 1 else "")
    central_value = getattr(config, "central_value_config", None)
    sizes = [("minibatch_size", config.minibatch_size)]
    if central_value is not None:
        sizes.append(("central_value_config.minibatch_size", central_value.minibatch_size))
    for key, size in sizes:
        if size > batch:
            raise ConfigError(source, f"params.config.{key}", f"minibatch_size {size} is larger than the batch "
                                                              f"{what} = {batch}")
        if batch % size != 0 and not (key == "minibatch_size" and config.minibatch_order == "rllib"):
            raise ConfigError(source, f"params.config.{key}", f"batch {what} = {batch} is not divisible by "
                                                              f"minibatch_size {size}")
