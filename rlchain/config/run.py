"""The keys every algorithm reads (:class:`RunConfig`) and the blocks they hold: the run, its env and
Ray env runners, stop rules, checkpoints, logging, evaluation, the player and divergence handling."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rlchain.config.fields import non_negative, option, positive, rate_target, unit_interval
from rlchain.config.hyperparam_schedule import check_hyperparam_schedule


@dataclass(frozen=True)
class RewardShaperConfig:
    """``reward_shaper``: r' = clip((r + shift_value) * scale_value, min_val, max_val)."""

    scale_value: float = option(1.0, "multiply rewards")
    shift_value: float = option(0.0, "add to rewards before scaling")
    min_val: float = option(float("-inf"), "clip shaped rewards below")
    max_val: float = option(float("inf"), "clip shaped rewards above")
    log_val: bool = option(False, "log of the shaped (scaled, shifted, clipped) reward, as rl_games; it must "
                                  "be > 0, e.g. with shift_value")

    @property
    def identity(self) -> bool:
        """Whether r' = r: the defaults (no shift, no scale, no clip, no log), so shaping can be skipped."""
        return (self.scale_value == 1.0 and self.shift_value == 0.0 and self.min_val == float("-inf")
                and self.max_val == float("inf") and not self.log_val)


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
    select_best: str = option("training", "what picks the best checkpoint nn/<name>.pth: the training or the "
                                          "evaluation mean reward, or evaluation_success: the evaluation success "
                                          "rate (ties: the higher evaluation reward; EmbodiChain's "
                                          "best_eval_metric eval/success_rate)",
                              choices=("training", "evaluation", "evaluation_success", "evaluation_length"))
    best_mode: str = option("max", "rlchain: with an evaluation select_best, whether the highest or the lowest "
                                   "score is the best (EmbodiChain's best_eval_mode; evaluation_length: mean "
                                   "episode length)", choices=("max", "min"))


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



PRECISIONS = (False, True, "bf16", "fp16")


def check_precision(value: Any) -> str | None:
    """``mixed_precision``: False, True, bf16 or fp16."""
    return None if any(value is p or value == p and type(value) is type(p) for p in PRECISIONS) \
        else f"expected False, True, bf16 or fp16, got {value!r}"


def amp_dtype_name(value: Any, bf16_supported: bool) -> str | None:
    """The autocast dtype ``mixed_precision`` asks for on a CUDA device: bfloat16 / float16 / None (off).
    True means bf16 as in rl_games 2.0, float16 where the GPU has no bf16."""
    if value is False or value is None:
        return None
    if value == "fp16" or (value is True and not bf16_supported):
        return "float16"
    return "bfloat16"


def _sync_stats(value: Any) -> str | None:
    return None if value is True else ("False is not supported: rlchain keeps the ranks' normalizer statistics "
                                       "in sync (pooled); remove the key")


def _sync_mode(value: Any) -> str | None:
    if value == "pooled":
        return None
    if value == "broadcast":
        return "broadcast (every rank takes rank 0's statistics) is not supported; rlchain pools them: use pooled"
    return f"expected pooled or broadcast, got {value!r}"


def _stop_fn(value: Any) -> str | None:
    if value is None:
        return None
    return (f"a callable(algo) -> bool comes through the rl_games API (rlchain.rl_games' Runner takes it in the "
            f"config dict), got {value!r}; in a YAML or rlchain.Runner use callbacks (ctx.request_stop)")


@dataclass(frozen=True)
class ProgressConfig:
    """``config.progress`` (rlchain): the console while training (``print_stats: True``).

    On a terminal a live status line (epoch / frames against the limit, ETA, fps, reward, success
    rate) stays under the epoch lines; off a terminal (a pipe, a file, CI, a notebook) the epoch
    lines are printed as plain text. The environment variable ``RLCHAIN_PROGRESS`` (``0``/``off`` or
    ``1``/``on``) wins over ``live``.
    """

    live: bool | None = option(None, "live status line: None = when stdout is a terminal (and rich is "
                                     "installed), false = never, true = always")
    print_every_epochs: int | None = option(None, "print the epoch line every N epochs (default: every epoch "
                                                  "off the live view, see print_every_seconds under it)",
                                            check=positive)
    print_every_seconds: float | None = option(None, "print the epoch line when this many seconds passed since "
                                                     "the last one (default: 10 under the live view, off "
                                                     "otherwise); with print_every_epochs, either one prints",
                                               check=non_negative)


def plain_name(value: Any) -> str | None:
    """A run name is a folder / file name, never a path: it cannot leave ``train_dir``."""
    if value is None:
        return None
    if not isinstance(value, str) or value.strip() == "":
        return "must be a non-empty name"
    if value.startswith("."):
        return "must not start with '.': it is a name, not a path"
    if "/" in value or "\\" in value or ".." in value:
        return "must be a plain name without '/', '\\' or '..': it is a name, not a path"
    if not value.isprintable():  # a newline, tab, NUL or other control character: a folder no shell shows right
        return f"must be printable: {value!r} holds a control character (newline, tab, ...)"
    return None


def _limit(value: Any) -> str | None:
    return "must not be 0 (it would stop before any training); use -1 for no limit" if value == 0 else None


@dataclass(frozen=True)
class EventConfig:
    """A ``config.events`` entry (rlchain; EmbodiChain's ``trainer.events.<train|eval>.<name>``)."""

    func: str = option(doc="package.module:function, called as fn(env, env_ids=None, **params) with the "
                           "training env (the EmbodiChain-contract env itself where the backend wraps one); or "
                           "video: record evaluation episodes (rlchain's VideoCallback; EmbodiChain's "
                           "record_camera_data functors)")
    phase: str = option("train", "train: every interval_step env steps of training; eval: after every "
                                 "interval_step-th in-training evaluation", choices=("train", "eval"))
    interval_step: int = option(1, "env steps (train) or evaluations (eval) between calls", check=positive)
    params: dict = option({}, "keyword arguments of func (video: save_path is the folder)")


@dataclass(frozen=True)
class RunConfig:
    """Keys every algorithm reads: the run, its env, stop conditions, checkpoints and logging.

    Each algorithm's ``params.config`` class derives from it (PPO's :class:`~rlchain.config.ppo.PPOConfig`,
    ``sac``, ``dqn``, ``appo``, ``impala``); a key only some algorithms read lives on their classes.
    """

    name: str = option("run", "run name: runs/<name>_<datetime>, best checkpoint nn/<name>.pth; a plain name "
                              "(no '/', backslash, '..' or leading '.')", check=plain_name)
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
    max_epochs: int = option(-1, "stop after this many epochs in total, resumes included (-1 = no limit; "
                                 "0 is an error)", check=_limit)
    max_frames: int = option(-1, "stop after this many env frames in total (-1 = no limit; 0 is an error)",
                             check=_limit)
    score_to_win: float = option(float("inf"), "stop once the mean reward reaches this")
    capability_manifest: dict | None = option(None, "rl_games 2.0: what the policy can do (command ranges, "
                                                     "terrains, ...), as the user declares it; never interpreted, "
                                                     "kept in the config and so in every checkpoint's stored "
                                                     "config")
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
    save_frequency_frames: int = option(0, "rlchain: write a periodic checkpoint at the first epoch end at or past "
                                           "each multiple of N env frames (summed over ranks; EmbodiChain's "
                                           "save_freq; 0 = off)", check=non_negative)
    checkpoint_names: str = option("rlchain", "checkpoint file names in nn/: rlchain's (<name>.pth, "
                                              "last_<name>.pth, <name>_ep_N.pth) or EmbodiChain's "
                                              "(<name>_best.pt, <name>_step_<frames>.pt, which also hold its "
                                              "global_step / policy / optimizer keys)",
                                   choices=("rlchain", "embodichain"))
    games_to_track: int = option(100, "episodes in the running mean reward", check=positive)
    print_stats: bool = option(True, "print the progress line every epoch")
    progress: ProgressConfig = option(ProgressConfig(), "how the progress line is shown: a live status on a "
                                                        "terminal, how often the epoch line (rlchain)")
    device: str = option("cuda:0", "cpu, cuda or cuda:N; falls back to cpu with a warning without CUDA")
    train_dir: str = option("runs", "folder that holds the run folders")
    full_experiment_name: str | None = option(None, "run folder name instead of <name>_<datetime>; a plain "
                                                    "name like name", check=plain_name)
    trust_checkpoint: bool = option(False, "rlchain: load the checkpoints this run reads (--checkpoint, a "
                                           "distillation teacher, watched ones) with full pickle, which runs any "
                                           "code stored in them; only for files you trust (same as "
                                           "--trust-checkpoint; never read from a checkpoint's stored config; "
                                           "see docs/reliability.md, Trusting files)")
    player: PlayerConfig = option(PlayerConfig(), "settings for --play")
    evaluation: EvaluationConfig = option(EvaluationConfig(), "in-training evaluation (rlchain)")
    callbacks: list[str] = option([], "callbacks to load, each 'package.module:Name' (rlchain)")
    events: list[EventConfig] = option([], "functions run during training or after evaluations (rlchain; "
                                           "what EmbodiChain's trainer.events become, docs/embodichain.md)")
    log_writers: list[str] = option([], "rlchain: extra log writers by registered name, e.g. [csv] "
                                        "(<run>/summaries/scalars.csv); each gets every scalar under its "
                                        "TensorBoard tag. Console, TensorBoard and (--track) wandb are always on; "
                                        "register yours with rlchain.runs.writers.register_writer")
    hyperparam_schedule: dict = option({}, "rlchain: {epoch: {name: value}}, live values set after that many "
                                           "epochs through set_params (0 = from the start), e.g. the schedule "
                                           "a PBT winner followed (--tune, docs/tuning.md); names from the "
                                           "algorithm's tunable", check=check_hyperparam_schedule)
    # a subclass changes a default or status with fields.variant
    vecenv_type: str | None = option(None, "vectorization backend: auto (native, sync), sync, async, "
                                           "envpool, RAY (Ray workers, see env_runners), or a name registered "
                                           "with rlchain.envs.vecenv.register (rl_games' vecenv.register); "
                                           "unset: the env_configurations entry's vecenv_type, else auto")
    num_actors: int = option(8, "parallel environments", check=positive)
    clip_actions: bool = option(True, "continuous: clip actions to [-1, 1] and rescale them to the action "
                                      "space bounds")
    multi_gpu: bool = option(False, "torch.distributed training: launch with `torchrun --nproc_per_node=N "
                                    "runner.py --train ...`; as in rl_games num_actors, horizon_length and "
                                    "minibatch_size are per process, gradients are averaged, rank 0 saves")
    multi_gpu_timeout_s: float = option(300.0, "rlchain, multi_gpu: seconds a collective (an all-reduce, a "
                                               "barrier) may wait for the other ranks; a rank that does not "
                                               "answer in time (stopped, wedged) ends the job on every rank",
                                        check=positive)
    mixed_precision: Any = option(False, "autocast of the PPO update's network passes: on CUDA True or bf16 = "
                                         "bfloat16 without grad scaling (rl_games 2.0's; float16 with grad "
                                         "scaling on a GPU without bf16), fp16 = float16 with grad scaling "
                                         "(rl_games 1.6's); on a CPU only bf16, where the CPU has native bf16 "
                                         "(AVX512-BF16/AMX; docs/benchmarks.md says what it gains; elsewhere a "
                                         "warning and float32), True and fp16 are "
                                         "float32 there as in rl_games; the rollout and the losses stay float32; "
                                         "False = off",
                                  check=check_precision)
    multi_gpu_sync_stats: bool = option(True, "multi_gpu (rl_games 2.0's key): the ranks' running normalizer "
                                              "statistics are kept in sync; rlchain always does so (False is an "
                                              "error)", check=_sync_stats)
    multi_gpu_sync_stats_mode: str = option("pooled", "multi_gpu (rl_games 2.0's key): pooled = every rank folds "
                                                      "in every rank's batch moments, so all ranks hold the "
                                                      "statistics of the pooled stream (rlchain's way); broadcast "
                                                      "(rank 0's statistics) is not supported",
                                            check=_sync_mode)
    stop_fn: Any = option(None, "rl_games 2.0: a callable(algo) -> bool checked after every epoch, true stops "
                                "the run with a checkpoint. A Python callable: rlchain.rl_games' Runner takes it in "
                                "the config dict; anywhere else it is an error (use callbacks)",
                          check=_stop_fn)
    divergence: DivergenceConfig = option(DivergenceConfig(), "NaN/inf handling (rlchain); rollback restores "
                                                             "the last good learner snapshot (off-policy: "
                                                             "taken every snapshot_epochs epochs)")

    # The checks an algorithm's config runs on itself, in this order, while the file is parsed
    # (rlchain.config.load.parse_params); an algorithm's class overrides the ones it needs.

    def resolved(self, source: str) -> RunConfig:
        """This config with its derived values filled in (cross-key checks raise ConfigError)."""
        return self

    def validate(self) -> tuple[str, str] | None:
        """A problem no single key shows: (key under params.config, message), or None."""
        return None

    def with_network(self, network: Any, source: str) -> RunConfig:
        """Checks against the parsed ``params.network`` (e.g. RNN sequences); the config, completed."""
        return self

