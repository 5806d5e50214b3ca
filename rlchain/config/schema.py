"""Typed configuration: every key of an rl_games ``params`` block, its default and its meaning.

Defaults live here once. ``docs/config.md`` is generated from these docstrings
(``python -m rlchain.config.docs``) and a test keeps it in sync.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from rlchain.config.compile import check_compile
from rlchain.config.fields import check_env_groups, non_negative, option, positive, rate_target, unit_interval
from rlchain.config.hyperparam_schedule import check_hyperparam_schedule
from rlchain.config.multi_agent import MultiAgentConfig

ACTIVATIONS = ("relu", "tanh", "sigmoid", "elu", "selu", "swish", "silu", "gelu", "softplus",
               "leaky_relu", "mish", "identity", "None")
INITIALIZERS = ("default", "const_initializer", "orthogonal_initializer", "glorot_normal_initializer",
                "glorot_uniform_initializer", "variance_scaling_initializer",
                "random_uniform_initializer", "kaiming_normal", "kaiming_uniform", "xavier_uniform",
                "xavier_normal", "None")


@dataclass(frozen=True)
class InitializerConfig:
    """A weight initializer as rl_games names it: ``{name: const_initializer, val: 0}``."""

    name: str = option("default", "initializer name", choices=INITIALIZERS)
    val: float = option(0.0, "constant for const_initializer")
    gain: float = option(1.0, "gain for orthogonal and glorot initializers")
    scale: float = option(1.0, "scale for variance_scaling_initializer")
    mode: str = option("fan_in", "fan mode for variance_scaling / kaiming", choices=("fan_in", "fan_out", "fan_avg"))
    distribution: str = option("truncated_normal", "variance_scaling distribution",
                               choices=("truncated_normal", "normal", "uniform", "untruncated_normal"))
    a: float = option(-0.1, "lower bound for random_uniform_initializer")
    b: float = option(0.1, "upper bound for random_uniform_initializer")
    nonlinearity: str = option("relu", "kaiming nonlinearity")


@dataclass(frozen=True)
class MlpConfig:
    """The fully connected trunk."""

    units: list[int] = option([256, 128, 64], "hidden layer sizes",
                              check=lambda u: None if all(x > 0 for x in u) else "every unit count must be > 0")
    activation: str = option("elu", "hidden activation", choices=ACTIVATIONS)
    initializer: InitializerConfig = option(InitializerConfig(), "hidden layer weight initializer")
    d2rl: bool = option(False, "D2RL: concatenate the input to every hidden layer")
    norm_only_first_layer: bool = option(False, "with normalization: only after the first layer")
    normalization: str | None = option(None, "layer_norm or batch_norm after hidden layers",
                                       choices=("layer_norm", "batch_norm"))


@dataclass(frozen=True)
class ConvSpec:
    """One convolution of ``cnn.convs``."""

    filters: int = option(doc="output channels", check=positive)
    kernel_size: int = option(doc="kernel size (square for conv2d)", check=positive)
    strides: int = option(1, "stride", check=positive)
    padding: int = option(0, "zero padding on each side", check=non_negative)


@dataclass(frozen=True)
class CnnConfig:
    """``network.cnn``: a convolutional encoder in front of the MLP (images or 1-d signals)."""

    type: str = option("conv2d", "conv2d over (C, H, W) or conv1d over (C, L) observations",
                       choices=("conv2d", "conv1d"))
    permute_input: bool = option(True, "observations are channels-last (H, W, C): permute to (C, H, W)")
    activation: str = option("relu", "activation after every convolution", choices=ACTIVATIONS)
    initializer: InitializerConfig = option(InitializerConfig(), "convolution weight initializer")
    convs: list[ConvSpec] = option([], "the convolutions, in order: {filters, kernel_size, strides, padding}",
                                   check=lambda c: None if c else "needs at least one convolution")


@dataclass(frozen=True)
class RnnConfig:
    """``network.rnn``: a recurrent layer; training uses sequences of ``config.seq_length``."""

    name: str = option("lstm", "lstm or gru", choices=("lstm", "gru"))
    units: int = option(128, "hidden units", check=positive)
    layers: int = option(1, "stacked recurrent layers", check=positive)
    before_mlp: bool = option(False, "recurrent layer before the MLP (after it when False)")
    layer_norm: bool = option(False, "LayerNorm on the recurrent output")
    concat_input: bool = option(False, "feed the network input to the recurrent layer alongside the trunk output")
    concat_output: bool = option(False, "append the network input (cnn output, or the flat obs) to the recurrent "
                                        "output")


@dataclass(frozen=True)
class DiscreteSpaceConfig:
    """``space.discrete``: a categorical head over ``Discrete(n)``."""


@dataclass(frozen=True)
class MultiDiscreteSpaceConfig:
    """``space.multi_discrete``: one categorical per action dimension (MultiDiscrete, Tuple of Discrete,
    MultiBinary); the head outputs sum(nvec) logits. Use with model ``multi_discrete_a2c``."""


@dataclass(frozen=True)
class ContinuousSpaceConfig:
    """``space.continuous``: a diagonal Gaussian head."""

    mu_activation: str = option("None", "activation on the mean", choices=ACTIVATIONS)
    sigma_activation: str = option("None", "activation on sigma (log-std for the logstd model)",
                                   choices=ACTIVATIONS)
    mu_init: InitializerConfig = option(InitializerConfig(), "mean head initializer")
    sigma_init: InitializerConfig = option(InitializerConfig(name="const_initializer", val=0.0),
                                           "sigma initializer ({name: const_initializer, val: 0})")
    fixed_sigma: bool = option(True, "sigma is a learned vector that does not depend on the input")


@dataclass(frozen=True)
class SpaceConfig:
    """Which action head: exactly one of discrete / multi_discrete / continuous."""

    discrete: DiscreteSpaceConfig | None = option(None, "categorical head", empty_is_present=True)
    multi_discrete: MultiDiscreteSpaceConfig | None = option(
        None, "one categorical per action dimension: MultiDiscrete, Tuple of Discrete, MultiBinary "
              "(model multi_discrete_a2c)", empty_is_present=True)
    continuous: ContinuousSpaceConfig | None = option(None, "diagonal Gaussian head", empty_is_present=True)


@dataclass(frozen=True)
class NetworkConfig:
    """``params.network`` for the built-in ``actor_critic`` builder."""

    name: str = option("actor_critic", "registered network builder")
    separate: bool = option(False, "separate critic network with the same architecture")
    space: SpaceConfig = option(SpaceConfig(), "action head")
    mlp: MlpConfig = option(MlpConfig(), "fully connected layers")
    cnn: CnnConfig | None = option(None, "convolutional encoder before the MLP")
    rnn: RnnConfig | None = option(None, "recurrent layer (lstm/gru)")
    normalization: str | None = option(None, "rl_games spelling at network level: layer_norm or batch_norm "
                                             "after MLP hidden layers", choices=("layer_norm", "batch_norm"))
    central_value: bool = option(False, "this network is a value-only critic (only inside "
                                        "config.central_value_config.network)")
    value_activation: str = option("None", "activation on the value output", choices=ACTIVATIONS)
    value_shape: int = option(1, "value outputs (overridden by the env's value_size)", check=positive)


@dataclass(frozen=True)
class ResnetCnnConfig:
    """``network.cnn`` of ``resnet_actor_critic``: IMPALA stages (conv 3x3, max-pool 3x3 / 2, two
    residual blocks) over (C, H, W) images."""

    permute_input: bool = option(True, "observations are channels-last (H, W, C): permute to (C, H, W)")
    conv_depths: list[int] = option([16, 32, 32], "output channels of each IMPALA stage",
                                    check=lambda d: None if d and all(x > 0 for x in d)
                                    else "needs at least one depth, each > 0")
    activation: str = option("relu", "activation inside the residual blocks (rl_games ignores the key and uses "
                                     "relu there); the flattened features get mlp.activation, as in rl_games",
                             choices=ACTIVATIONS)
    initializer: InitializerConfig = option(InitializerConfig(), "convolution weight initializer; default: "
                                                                 "kaiming_normal (fan_out, relu) as rl_games")


@dataclass(frozen=True)
class ResnetNetworkConfig:
    """``params.network`` for the ``resnet_actor_critic`` builder (rl_games' IMPALA network): the
    ``cnn`` stages, then ``mlp`` and ``rnn`` as in ``actor_critic``, and the heads.

    ``require_rewards`` / ``require_last_actions`` feed the previous (clipped) reward and the
    one-hot previous action to the recurrent layer, beside the image features (to the MLP when there
    is no ``rnn``). The env supplies them: ``env_config.use_dict_obs_space: True`` (envpool) or
    ``wrap_impala: True`` (atari_gym), see rlchain/envs/wrappers/reward_action_obs.py.
    """

    name: str = option("resnet_actor_critic", "registered network builder")
    separate: bool = option(False, "separate critic network with the same architecture")
    space: SpaceConfig = option(SpaceConfig(), "action head")
    cnn: ResnetCnnConfig = option(ResnetCnnConfig(), "IMPALA residual encoder")
    mlp: MlpConfig = option(MlpConfig(), "fully connected layers after the encoder")
    rnn: RnnConfig | None = option(None, "recurrent layer (lstm/gru)")
    normalization: str | None = option(None, "layer_norm or batch_norm after MLP hidden layers",
                                       choices=("layer_norm", "batch_norm"))
    value_activation: str = option("None", "activation on the value output", choices=ACTIVATIONS)
    value_shape: int = option(1, "value outputs (overridden by the env's value_size)", check=positive)
    require_rewards: bool = option(False, "the previous reward (clipped to [-1, 1]) as an input of the "
                                          "recurrent layer; needs env_config.use_dict_obs_space (envpool) "
                                          "or wrap_impala (atari_gym)")
    require_last_actions: bool = option(False, "the previous action (one-hot) as an input of the recurrent "
                                               "layer; same env keys as require_rewards")


@dataclass(frozen=True)
class RewardShaperConfig:
    """``reward_shaper``: r' = clip((r + shift_value) * scale_value, min_val, max_val)."""

    scale_value: float = option(1.0, "multiply rewards")
    shift_value: float = option(0.0, "add to rewards before scaling")
    min_val: float = option(float("-inf"), "clip shaped rewards below")
    max_val: float = option(float("inf"), "clip shaped rewards above")
    log_val: bool = option(False, "log of the shaped (scaled, shifted, clipped) reward, as rl_games; it must "
                                  "be > 0, e.g. with shift_value")


@dataclass(frozen=True)
class PlayerConfig:
    """``config.player``: inference settings for ``--play``."""

    render: bool = option(False, "render the env while playing")
    render_sleep: float = option(0.002, "seconds to sleep between rendered frames", check=non_negative)
    deterministic: bool = option(True, "act with the distribution's mode instead of sampling")
    games_num: int = option(2000, "episodes to play", check=positive)
    n_game_life: int = option(1, "lives per game (rl_games scales per-life averages by it); accepted, not needed: "
                                 "Atari games are always counted whole, see docs/environments.md (Atari)",
                                 check=positive)
    print_stats: bool = option(True, "print each finished game")
    use_vecenv: bool = option(False, "play with several envs at once (num_actors of the player)")
    num_actors: int = option(1, "envs stepped together while playing", check=positive)
    evaluation: bool = option(False, "watch dir_to_monitor and evaluate new checkpoints",
                              status="yes")
    update_checkpoint_freq: int = option(100, "with evaluation: games between checkpoint reloads",
                                         status="yes")
    dir_to_monitor: str | None = option(None, "with evaluation: folder to watch", status="yes")
    env_config: dict = option({}, "env_config overrides used only by the player")
    games_to_track: int = option(100, "unused, accepted for rl_games configs", status="deprecated")


@dataclass(frozen=True)
class EvaluationConfig:
    """``config.evaluation`` (rlchain): play games with the current policy during training."""

    interval: int = option(0, "evaluate every N epochs (0 = off)", check=non_negative)
    games: int = option(10, "episodes per evaluation", check=positive)
    deterministic: bool = option(True, "act with the distribution's mode")
    num_envs: int = option(4, "evaluation envs, separate from the training envs", check=positive)
    seed: int = option(10_000, "evaluation env seed (the same every evaluation, so scores compare)")
    select_best: str = option("training", "which mean reward picks the best checkpoint nn/<name>.pth",
                              choices=("training", "evaluation"))


@dataclass(frozen=True)
class DivergenceConfig:
    """``config.divergence`` (rlchain): what to do when a loss, gradient or parameter turns NaN/inf."""

    action: str = option("stop", "stop: end the run with a message; rollback: restore the last good "
                                 "epoch and scale the learning rate", choices=("stop", "rollback"))
    max_rollbacks: int = option(3, "rollbacks allowed before the run stops", check=non_negative)
    lr_factor: float = option(0.5, "learning-rate multiplier applied at each rollback",
                              check=lambda x: None if 0 < x <= 1 else "must be in (0, 1]")


@dataclass(frozen=True)
class EnvRunnersConfig:
    """``config.env_runners`` (rlchain): step the training envs on Ray actors (``pip install rlchain[ray]``).

    This block, or ``vecenv_type: RAY`` (rl_games' name; the block's defaults), turns it on. The
    ``num_actors`` envs are split over the workers; each worker builds its slice with the backend
    ``vecenv_type`` names (RAY: auto). Details: rlchain/envs/ray/ray_env.py.
    """

    num_workers: int | None = option(None, "Ray actors stepping the envs (default: num_actors / envs_per_worker "
                                           "when that is set, else 2, at most num_actors)", check=positive)
    envs_per_worker: int | None = option(None, "envs per worker; num_workers * envs_per_worker must equal "
                                               "num_actors (default: num_actors split evenly)", check=positive)
    address: str | None = option(None, "None: start a local Ray (or use the one this process started); "
                                       "'auto', 'host:port' or 'ray://host:10001': an existing cluster")
    num_cpus_per_worker: float = option(1.0, "CPUs each worker reserves from Ray", check=non_negative)
    max_restarts: int = option(3, "restarts of a dead worker allowed (each worker) before the run stops",
                               check=non_negative)
    step_timeout_s: float = option(60.0, "a worker that does not answer a step or reset within this is "
                                         "treated as dead", check=positive)
    start_timeout_s: float = option(120.0, "seconds a (re)started worker may take to build its envs",
                                    check=positive)
    runtime_env: dict = option({}, "Ray runtime_env for ray.init (e.g. {pip: [rlchain]} on a cluster)")


@dataclass(frozen=True)
class SelfPlayConfig:
    """``config.self_play_config``: train against frozen copies of the policy loaded into the env.

    The env provides ``set_opponent(policy, env_ids)`` (see rlchain/training/self_play.py). After
    every epoch the mean score of the games finished since the last opponent update is checked;
    once ``games_to_check`` games are in and it is above ``update_score``, a frozen copy of the
    current policy becomes the opponent of ``env_update_num`` envs.
    """

    update_score: float = option(doc="replace the opponent once the mean score is above this (e.g. a win "
                                     "rate with check_scores, a mean episode reward without)")
    games_to_check: int = option(doc="games (since the last update) the mean score is taken over",
                                 check=positive)
    check_scores: bool = option(False, "score = the env's per-game scores (pop_scores(): win 1, draw 0.5, "
                                       "loss 0) instead of the episode rewards")
    env_update_num: int = option(1, "envs that get the new opponent per update: a window of envs that moves "
                                    "on by one env per update, as in rl_games", check=positive)
    deterministic: bool = option(False, "the frozen opponent acts with its distribution's mode instead of "
                                        "sampling (rlchain)")


def _check_lr(x: float) -> str | None:
    return None if x > 0 else "must be > 0"


@dataclass(frozen=True)
class RunConfig:
    """Keys every algorithm shares: the run, its env, stop conditions, checkpoints and logging."""

    name: str = option("run", "run name: runs/<name>_<datetime>, best checkpoint nn/<name>.pth")
    env_name: str = option("", "gymnasium id, `openai_gym` (env_config.name), `envpool` "
                               "(env_config.env_name), `atari_gym` (env_config.name, an ale-py id) or a "
                               "registered env")
    env_config: dict = option({}, "keyword arguments for the environment; with env_name envpool also "
                                  "rlchain's `action_repeat` (env steps per action, default 1: rewards summed, "
                                  "an ending episode stops there)")
    env_runners: EnvRunnersConfig | None = option(None, "step the envs on Ray workers (rlchain; see the "
                                                            "env_runners section)")
    gamma: float = option(0.99, "discount", check=unit_interval)
    normalize_input: bool = option(False, "running mean/std normalization of observations (clipped to +-5); "
                                          "each PPO update trains with statistics that include its rollout")
    reward_shaper: RewardShaperConfig = option(RewardShaperConfig(), "reward scaling and clipping")
    max_epochs: int = option(-1, "stop after this many epochs in total, resumes included (-1 = no limit)")
    max_frames: int = option(-1, "stop after this many env frames in total (-1 = no limit)")
    score_to_win: float = option(float("inf"), "stop once the mean reward reaches this")
    success_to_win: float = option(float("inf"), "stop once the success rate of the tracked episodes reaches "
                                                  "this (0..1; envs that report success, see success_key)",
                                  check=rate_target)
    success_key: str = option("auto", "info key holding task success (rlchain): auto = `success` (MetaWorld, "
                                      "MuJoCo Playground), else `is_success` (gymnasium-robotics); none = off. "
                                      "Logged as episodes/success_rate")
    log_info_keys: list[str] = option([], "numeric step-info keys to average over each epoch's env steps and log "
                                          "as env_info/<key> (rlchain; e.g. a robot task's reward terms: "
                                          "reward_box_target)")
    success_mode: str = option("any", "an episode succeeded when the success value was true at any of its "
                                      "steps (MetaWorld's rule) or at its last step (gymnasium-robotics')",
                               choices=("any", "last"))
    save_best_after: int = option(100, "epochs before the best checkpoint is written", check=non_negative)
    save_frequency: int = option(0, "write a periodic checkpoint every N epochs (0 = off)",
                                 check=non_negative)
    games_to_track: int = option(100, "episodes in the running mean reward", check=positive)
    print_stats: bool = option(True, "print the progress line every epoch")
    device: str = option("cuda:0", "cpu, cuda or cuda:N; falls back to cpu with a warning without CUDA")
    train_dir: str = option("runs", "folder that holds the run folders")
    full_experiment_name: str | None = option(None, "run folder name instead of <name>_<datetime>")
    player: PlayerConfig = option(PlayerConfig(), "settings for --play")
    evaluation: EvaluationConfig = option(EvaluationConfig(), "in-training evaluation (rlchain)")
    torch_compile: Any = option(False, "PPO: torch.compile the network: false, true (mode default), a mode "
                                       "(default, reduce-overhead, max-autotune) or {mode, critic_mode, "
                                       "backend}. rl_games defaults to true; rlchain to false (compiling "
                                       "costs ~30 s on a CPU)", check=check_compile)
    callbacks: list[str] = option([], "callbacks to load, each 'package.module:Name' (rlchain)")
    log_writers: list[str] = option([], "rlchain: extra log writers by registered name, e.g. [csv] "
                                        "(<run>/summaries/scalars.csv); each gets every scalar under its "
                                        "TensorBoard tag. Console, TensorBoard and (--track) wandb are always on; "
                                        "register yours with rlchain.runs.writers.register_writer")
    hyperparam_schedule: dict = option({}, "rlchain: {epoch: {name: value}}, live values set after that many "
                                           "epochs through set_params (0 = from the start), e.g. the schedule "
                                           "a PBT winner followed (--tune, docs/tuning.md); names from the "
                                           "algorithm's tunable", check=check_hyperparam_schedule)
    # declared here once for every algorithm; a subclass changes a default or status with fields.variant
    vecenv_type: str | None = option(None, "vectorization backend: auto (native, sync), sync, async, "
                                           "envpool, RAY (Ray workers, see env_runners), or a name registered "
                                           "with rlchain.envs.vecenv.register (rl_games' vecenv.register); "
                                           "unset: the env_configurations entry's vecenv_type, else auto")
    num_actors: int = option(8, "parallel environments", check=positive)
    clip_actions: bool = option(True, "continuous: clip actions to [-1, 1] and rescale them to the action "
                                      "space bounds")
    seq_length: int = option(4, "RNN: steps per training sequence; horizon_length and minibatch_size must "
                                "divide by it (the deprecated `seq_len` is read as this, with a warning)",
                             check=positive)
    multi_gpu: bool = option(False, "torch.distributed training: launch with `torchrun --nproc_per_node=N "
                                    "runner.py --train ...`; as in rl_games num_actors, horizon_length and "
                                    "minibatch_size are per process, gradients are averaged, rank 0 saves")
    mixed_precision: bool = option(False, "autocast + grad scaling on CUDA; no-op on CPU")
    divergence: DivergenceConfig = option(DivergenceConfig(), "NaN/inf handling (rlchain); rollback restores "
                                                             "the last good learner snapshot (off-policy: "
                                                             "taken every snapshot_epochs epochs)")


@dataclass(frozen=True)
class TrainConfig(RunConfig):
    """``params.config``: the training keys of an rl_games config."""

    not_for_this_algo: ClassVar[dict[str, str]] = {"appo": "it configures algos appo and impala"}

    env_groups: Any = option("auto", "rlchain, envpool: split the envs into this many groups that step in "
                                     "the background while the policy acts for the other (overlaps env "
                                     "stepping with inference); auto = 2 when num_actors is even and >= "
                                     "16, else 1. Must divide num_actors", check=check_env_groups)
    horizon_length: int = option(32, "steps per env per epoch; batch = num_actors * horizon_length * "
                                     "agents per env", check=positive)
    minibatch_size: int | None = option(None, "minibatch size; the batch must divide by it (this or "
                                              "minibatch_size_per_env is required)", check=positive)
    minibatch_size_per_env: int | None = option(None, "minibatch = num_actors * this", check=positive)
    mini_epochs: int = option(4, "passes over the batch per epoch", check=positive)
    minibatch_order: str = option("auto", "which steps each minibatch holds. fixed = rl_games' order: the "
                                          "rollout flattened env by env and cut in turn, so minibatch k is the "
                                          "same whole env trajectories (whole sequences for an RNN) in every "
                                          "mini-epoch; shuffle = a new random permutation every mini-epoch; "
                                          "auto = fixed for continuous actions (measured better on the MuJoCo "
                                          "YAMLs, docs/ppo_parity.md), shuffle otherwise",
                                  choices=("auto", "fixed", "shuffle"))
    tau: float = option(0.95, "GAE lambda", check=unit_interval)
    learning_rate: float = option(3e-4, "Adam learning rate", check=_check_lr)
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
    decay_power: float = option(1.0, "polynom_decay: the exponent (1 = linear; rl_games' TensorFlow agent's key; "
                                     "its torch agent keeps a polynom_decay lr constant)", check=positive)
    e_clip: float = option(0.2, "PPO clip range", check=positive)
    clip_value: bool = option(False, "clip the value update to e_clip around the old value")
    critic_coef: float = option(1.0, "critic loss weight: loss += critic_coef * 0.5 * value loss",
                                check=non_negative)
    entropy_coef: float = option(0.0, "entropy bonus weight")
    schedule_entropy: bool = option(False, "with lr_schedule linear: the entropy bonus weight moves linearly from "
                                           "entropy_coef to 1e-4 alongside the lr (logged as info/entropy_coef); "
                                           "no effect with another lr_schedule (a warning), as in rl_games")
    normalize_advantage: bool = option(True, "normalize advantages over the whole batch")
    normalize_value: bool = option(False, "running mean/std normalization of value targets (statistics of the "
                                          "returns, not clipped; rl_games also folds the rollout's values in and "
                                          "clips at +-5: measured worse, see docs/ppo_parity.md)")
    normalize_rms_advantage: bool = option(False, "running-stat advantage normalization",
                                           status="planned")
    adv_rms_momentum: float = option(0.5, "with normalize_rms_advantage", status="planned")
    freeze_critic: bool = option(False, "train the actor only", status="planned")
    epochs_between_resets: int = option(0, "reset all envs every N epochs", status="planned")
    value_bootstrap: bool = option(True, "on time-out bootstrap V(true final obs) instead of a terminal")
    timeout_bootstrap: str = option("final_obs", "with value_bootstrap, the value a time-out bootstraps (rlchain): "
                                                 "final_obs = V(the true final observation); previous_value = "
                                                 "V(the state before the last step), as rl_games (reward += "
                                                 "gamma * V(s_t)); see docs/ppo_parity.md",
                                    choices=("final_obs", "previous_value"))
    grad_norm: float = option(1.0, "max gradient norm when truncate_grads", check=positive)
    truncate_grads: bool = option(False, "clip gradients to grad_norm")
    weight_decay: float = option(0.0, "Adam weight decay", check=non_negative)
    bounds_loss_coef: float | None = option(None, "continuous: weight of the bounds loss (None = off)",
                                            check=non_negative)
    bound_loss_type: str = option("bound", "bound (mean beyond +-1.1) or regularisation (sum mu^2)",
                                  choices=("bound", "regularisation"))
    use_smooth_clamp: bool = option(False, "smooth clamp instead of clamp in the clipped objective")
    bptt_length: int | None = option(None, "RNN: backpropagate through at most this many steps of a "
                                           "sequence (truncated BPTT; default: the whole seq_length)",
                                     check=positive)
    zero_rnn_on_done: bool = option(True, "RNN: zero the hidden state when an episode ends, in the rollout "
                                          "and inside training sequences")
    central_value_config: CentralValueConfig | None = option(
        None, "asymmetric actor-critic: a value network on the env's `state` (env use_central_value)")
    use_action_masks: bool = option(False, "invalid-action masks from the env's has_action_mask() / "
                                           "get_action_mask() (discrete and multi-discrete actions)")
    self_play_config: SelfPlayConfig | None = option(None, "self-play: frozen copies of the policy as the "
                                                           "env's opponent (needs env set_opponent)")
    multi_agent: MultiAgentConfig | None = option(None, "PettingZoo agents played by several policies, each "
                                                        "with its own model and optimizer (env_name: "
                                                        "pettingzoo; docs/multi_agent.md)")
    use_diagnostics: bool = option(False, "extra TensorBoard diagnostics (clip fraction, explained variance)")
    value_size: int | None = option(None, "value outputs (normally from the env)", status="planned (issue 3)")


@dataclass(frozen=True)
class CentralValueConfig:
    """``config.central_value_config``: a critic that sees the env's full ``state`` while the actor
    sees ``obs`` (asymmetric actor-critic). It has its own network, optimizer and minibatches; the
    actor's own value head is then not trained. Needs an env with ``use_central_value = True``.
    """

    # parsed in load.py like params.network: a NetworkConfig for actor_critic, the raw dict for a user builder
    network: Any = option(doc="the critic's network block: actor_critic (mlp, cnn, rnn; `central_value: True`; "
                              "no action head) or a registered network, built with `central_value: True` and "
                              "returning (value, states)")
    learning_rate: float = option(5e-4, "critic Adam learning rate", check=_check_lr)
    lr_schedule: str | None = option(None, "None (constant) or linear (to 0 over max_epochs/max_frames)",
                                     choices=("linear", "constant"))
    minibatch_size: int | None = option(None, "critic minibatch size (default: the actor's)", check=positive)
    minibatch_size_per_env: int | None = option(None, "critic minibatch = num_actors * this", check=positive)
    mini_epochs: int = option(4, "critic passes over the batch per epoch", check=positive)
    normalize_input: bool = option(True, "running mean/std normalization of states")
    clip_value: bool = option(False, "clip the value update to e_clip around the old value")
    e_clip: float = option(0.2, "value clip range", check=positive)
    truncate_grads: bool = option(False, "clip gradients to grad_norm")
    grad_norm: float = option(1.0, "max gradient norm", check=positive)
    weight_decay: float = option(0.0, "Adam weight decay", check=non_negative)


@dataclass(frozen=True)
class NamedBlock:
    """``params.algo`` / ``params.model``: a registered name."""

    name: str = option(doc="registered name")


@dataclass(frozen=True)
class Params:
    """The whole ``params`` block after parsing."""

    algo: NamedBlock
    model: NamedBlock
    config: TrainConfig
    network: Any = None  # NetworkConfig for built-in builders, the raw dict for user builders
    seed: int | None = None
    import_modules: list[str] | None = None
    torch_threads: int | None = None  # torch.set_num_threads for this process (rl_games key)
    update_threads: int | None = None  # CPU threads for the gradient updates (default: all cores, at most 4)
    source: str = ""
    policies: dict[str, Params] | None = None  # config.multi_agent: each policy's own Params (load.py)
