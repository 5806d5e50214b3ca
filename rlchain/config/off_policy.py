"""Typed ``params.config`` for the off-policy algorithms (``sac``, ``dqn``).

The algorithm registered in ALGOS names its dataclass as ``config_class``; ``parse_params`` then
parses ``params.config`` with it instead of PPO's :class:`~rlchain.config.ppo.PPOConfig`.
The generic rl_games keys (run name, env, stop conditions, checkpoints, player: :class:`~rlchain.config.run.
RunConfig`) mean the same as for PPO.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from rlchain.config.actor_critic import ActorCriticConfig
from rlchain.config.fields import non_negative, option, positive, unit_interval, variant
from rlchain.config.network import MlpConfig, SpaceConfig
from rlchain.config.ppo import PPOConfig
from rlchain.config.run import RunConfig


def _check_lr(x: float) -> str | None:
    return None if x > 0 else "must be > 0"


def _check_mean_clip(c: float | None) -> str | None:
    if c is not None and (isinstance(c, bool) or not isinstance(c, (int, float)) or not c > 0):
        return "must be a number > 0, or null for no clip"
    return None


def _check_bounds(b: list[float]) -> str | None:
    if len(b) != 2 or not b[0] < b[1]:
        return "must be [low, high] with low < high"
    return None


@dataclass(frozen=True)
class HERConfig:
    """``config.replay.her`` (rlchain): hindsight experience replay for goal envs (Dict observations with
    achieved_goal / desired_goal and a compute_reward; see rlchain/algos/off_policy/her.py)."""

    strategy: str = option("future", "where hindsight goals come from: future = the goal achieved at a random "
                                     "later step of the same episode, final = at its last step",
                           choices=("future", "final"))
    k: int = option(4, "hindsight goals per real goal: k / (k + 1) of each minibatch is relabelled", check=positive)


@dataclass(frozen=True)
class ReplayConfig:
    """``config.replay`` (rlchain): replay buffer extensions."""

    her: HERConfig | None = option(None, "hindsight experience replay, e.g. {strategy: future, k: 4}",
                                   empty_is_present=True)


@dataclass(frozen=True)
class OffPolicyConfig(RunConfig):
    """Keys shared by every off-policy algorithm (generic rl_games keys + the replay buffer)."""

    num_actors: int = variant(RunConfig, "num_actors", default=1)
    num_steps_per_episode: int = option(1, "env steps per env per epoch (frames per epoch = "
                                           "num_actors * num_steps_per_episode)", check=positive)
    num_updates_per_step: int = option(1, "gradient updates after every update_every-th vectorized env step",
                                       check=positive)
    update_every: int = option(1, "vectorized env steps from one round of num_updates_per_step updates to the "
                                  "next (rlchain key; SB3's train_freq, RLlib's sampling rounds per update): "
                                  "the round follows the run's update_every-th, 2 x update_every-th, ... step",
                               check=positive)
    utd_ratio: float | None = option(None, "rl_games 2.0: gradient updates per env frame; sets "
                                           "num_updates_per_step = max(1, round(utd_ratio * num_actors)), "
                                           "overriding it", check=positive)
    num_warmup_frames: int | None = option(None, "frames of uniformly random actions before learning starts "
                                                 "(default 1000, or from num_warmup_steps)", check=non_negative)
    num_warmup_steps: int | None = option(None, "rl_games' older warmup in epochs: num_warmup_frames = this * "
                                                "num_actors * num_steps_per_episode when that is not given",
                                          check=non_negative)
    batch_size: int = option(256, "replay minibatch size", check=positive)
    replay_buffer_size: int = option(100_000, "replay buffer capacity in transitions", check=positive)
    n_step: int = option(1, "n-step returns (1 = one-step TD)", check=positive)
    n_step_max: int | None = option(None, "with it, each stored transition's n is drawn uniformly from [n_step, "
                                          "n_step_max] (RLlib's n_step range); None: n_step for every one",
                                    check=positive)
    prioritized_replay: bool = option(False, "proportional prioritized replay (sum-tree)")
    priority_alpha: float = option(0.6, "prioritized replay: priority exponent", check=non_negative)
    priority_beta: float = option(0.4, "prioritized replay: initial importance-sampling exponent, annealed "
                                       "to 1 over max_frames (or max_epochs)", check=unit_interval)
    replay: ReplayConfig = option(ReplayConfig(), "replay buffer extensions (rlchain): her")
    obs_normalizer_exclude: list[str] = variant(ActorCriticConfig, "obs_normalizer_exclude")
    save_replay_buffer: bool = option(False, "store the replay buffer's contents in every checkpoint "
                                             "(exact resume of off-policy runs; large files, the size is printed)")
    mixed_precision: bool = variant(RunConfig, "mixed_precision", doc="autocast on CUDA",
                                    status="planned (off-policy AMP)")
    multi_gpu: bool = variant(RunConfig, "multi_gpu", doc="torch.distributed training",
                              status="planned (torchrun is PPO-only for now)")
    seq_length: int = variant(PPOConfig, "seq_length", doc="RNN sequence length",
                              status="accepted; no effect off-policy")
    torch_compile: Any = variant(PPOConfig, "torch_compile")  # accepted as false only (validate)
    snapshot_epochs: int = option(100, "divergence rollback: epochs between in-memory learner snapshots "
                                       "(rlchain; an off-policy epoch is num_steps_per_episode env steps)",
                                  check=positive)

    def __post_init__(self) -> None:
        """num_warmup_frames from num_warmup_steps when not given (rl_games: frames take priority over
        steps, which are epochs); set once, while the frozen value is built."""
        if self.num_warmup_frames is None:
            steps = self.num_warmup_steps
            frames = 1000 if steps is None else steps * self.num_actors * self.num_steps_per_episode
            object.__setattr__(self, "num_warmup_frames", frames)
        if self.utd_ratio is not None and isinstance(self.utd_ratio, (int, float)) and self.utd_ratio > 0:
            object.__setattr__(self, "num_updates_per_step", max(1, round(self.utd_ratio * self.num_actors)))

    def validate(self) -> tuple[str, str] | None:
        """Cross-key checks; returns (key, message) for the first problem."""
        if not self.env_name:
            return "env_name", "required key is missing"
        if self.batch_size > self.replay_buffer_size:
            return "batch_size", (f"batch_size {self.batch_size} is larger than replay_buffer_size "
                                  f"{self.replay_buffer_size}")
        if self.n_step_max is not None and self.n_step_max < self.n_step:
            return "n_step_max", f"n_step_max {self.n_step_max} is below n_step {self.n_step}"
        if self.replay.her is not None and (self.n_step != 1 or self.n_step_max or self.prioritized_replay):
            return "replay.her", "hindsight replay works with n_step 1 and prioritized_replay False"
        if self.torch_compile not in (False, None, "false", "False"):
            return "torch_compile", "supported for PPO only so far; remove it or set false"
        return None


@dataclass(frozen=True)
class SACConfig(OffPolicyConfig):
    """``params.config`` for algo ``sac`` (soft actor-critic, twin critics, a learned temperature; a tanh-squashed
    Gaussian policy on Box actions, a categorical one with per-action critics on Discrete actions)."""

    # words for its heading in docs/config.md
    doc_note: ClassVar[str] = "keys shared with PPO have the same meaning"

    init_alpha: float = option(1.0, "initial entropy temperature", check=positive)
    alpha_lr: float = option(3e-4, "temperature learning rate", check=_check_lr)
    actor_lr: float = option(3e-4, "actor learning rate", check=_check_lr)
    critic_lr: float = option(3e-4, "critic learning rate", check=_check_lr)
    critic_tau: float = option(0.005, "Polyak factor of the target critics (1 = hard copy)",
                               check=lambda x: None if 0 < x <= 1 else "must be in (0, 1]")
    learnable_temperature: bool = option(True, "learn alpha towards target_entropy")
    target_entropy: float | None = option(None, "entropy target for alpha (default -action_dim for Box actions; "
                                                "0.98 * log(n) for Discrete(n): Christodoulou 2019)")
    policy_frequency: int = option(1, "actor (and alpha) update every N critic updates", check=positive)
    log_std_bounds: list[float] | None = option(None, "[min, max] of the policy log-std (overrides the "
                                                      "network block's log_std_bounds)", check=_check_bounds)
    grad_norm: float | None = option(None, "clip gradient norms to this (None = off)", check=positive)
    loss: str = option("mse", "TD loss of each critic: mse (rl_games, SB3) or huber (RLlib's, delta 1)",
                       choices=("mse", "huber"))
    mixed_precision: bool = variant(RunConfig, "mixed_precision", doc="bf16 autocast of the critic and actor "
                                    "updates on a CUDA GPU with bf16 (rl_games 2.0, no grad scaler); one warning and "
                                    "float32 elsewhere (a CPU)", status="yes")


@dataclass(frozen=True)
class DQNConfig(OffPolicyConfig):
    """``params.config`` for algo ``dqn`` (double DQN with a target network, epsilon-greedy)."""

    learning_rate: float = option(1e-3, "Adam learning rate", check=_check_lr)
    double_dqn: bool = option(True, "double DQN: the online net picks the next action, the target rates it")
    target_update_frequency: int = option(500, "gradient updates between target network updates",
                                          check=positive)
    target_tau: float = option(1.0, "target update factor (1 = hard copy)",
                               check=lambda x: None if 0 < x <= 1 else "must be in (0, 1]")
    epsilon_start: float = option(1.0, "initial exploration epsilon", check=unit_interval)
    epsilon_end: float = option(0.05, "final exploration epsilon", check=unit_interval)
    epsilon_decay_frames: int = option(10_000, "frames (after warmup) of linear epsilon decay", check=positive)
    play_epsilon: float = option(0.0, "epsilon of stochastic (deterministic: False) play", check=unit_interval)
    loss: str = option("huber", "TD loss", choices=("huber", "mse"))
    grad_norm: float | None = option(10.0, "clip gradient norms to this (None = off)", check=positive)


@dataclass(frozen=True)
class SACNetworkConfig:
    """``params.network`` for the ``soft_actor_critic`` builder (rl_games' keys)."""

    name: str = option("soft_actor_critic", "registered network builder")
    separate: bool = option(True, "actor and critics never share layers (always True)")
    space: SpaceConfig = option(SpaceConfig(), "action head (continuous)")
    mlp: MlpConfig = option(MlpConfig(units=[256, 256], activation="relu"), "actor and critic hidden layers")
    log_std_bounds: list[float] = option([-5.0, 2.0], "[min, max] of the policy log-std", check=_check_bounds)
    mean_clip: float | None = option(None, "clip the policy's pre-tanh mean to [-mean_clip, mean_clip] (SB3's "
                                           "SAC actor with gSDE: clip_mean 2); null: no clip",
                                     check=_check_mean_clip)
    normalization: str | None = option(None, "rl_games 2.0's network-level spelling: layer_norm or batch_norm after "
                                             "the hidden layers of the actor and both critics (as mlp.normalization)",
                                       choices=("layer_norm", "batch_norm"))


@dataclass(frozen=True)
class DQNNetworkConfig:
    """``params.network`` for the ``dqn`` builder."""

    name: str = option("dqn", "registered network builder")
    space: SpaceConfig = option(SpaceConfig(), "action head (discrete)")
    mlp: MlpConfig = option(MlpConfig(units=[128, 128], activation="relu"), "hidden layers")
    dueling: bool = option(True, "dueling head: Q = V + A - mean(A)")
    head: MlpConfig | None = option(None, "hidden layers of each output stream after the trunk (the advantage "
                                          "and, dueling, the value stream each get their own, as RLlib's "
                                          "head_fcnet_hiddens); None: one linear layer each")
