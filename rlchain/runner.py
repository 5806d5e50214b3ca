"""The Python API behind runner.py: load a config, then train or play.

    from rlchain import Runner
    result = Runner().load("cfg.yaml", overrides=["params.config.max_epochs=10"]).train()
    Runner().load("cfg.yaml").play(checkpoint="nn/cartpole.pth")
"""

from __future__ import annotations

import copy
import os
import warnings
from dataclasses import dataclass
from typing import Any

import yaml

from rlchain.algos.appo.appo import APPO, IMPALA
from rlchain.algos.multi_off_policy.algorithm import MultiPolicyOffPolicy
from rlchain.algos.multi_off_policy.learner import AGENTS
from rlchain.algos.multi_policy.multi_policy import MultiPolicyPPO
from rlchain.algos.multi_policy.multi_policy_vtrace import MultiPolicyAPPO, MultiPolicyIMPALA
from rlchain.config.embodichain import is_embodichain
from rlchain.config.errors import ConfigError
from rlchain.config.load import (
    apply_overrides,
    check_seed,
    from_embodichain,
    import_user_modules,
    load_raw,
    parse_params,
)
from rlchain.config.packaged import checkpoint_names, resolve_checkpoint, resolve_config
from rlchain.config.params import Params
from rlchain.config.resolve import CONFIG_FORMAT, ProcessContext, params_from_state, resolve
from rlchain.config.stored import as_data
from rlchain.envs.known import check_stored_env
from rlchain.envs.spec import env_spec
from rlchain.errors import did_you_mean
from rlchain.inference.export.onnx import export_from_cli
from rlchain.inference.export.policies import export_policies
from rlchain.inference.player import Player
from rlchain.inference.policy_player import play_policies
from rlchain.inference.video import record_episodes
from rlchain.log import get_logger
from rlchain.models.build import apply_sigma, build_model
from rlchain.parallel import communicator, distributed
from rlchain.parallel.device import on_available_device, resolve_device
from rlchain.parallel.memory import tune_malloc
from rlchain.parallel.threads import ThreadPlan, for_env, set_threads
from rlchain.registry import ALGOS
from rlchain.runs import checkpoint as ckpt
from rlchain.runs.checkpoint import seed_everything
from rlchain.runs.logging import TrainLogger
from rlchain.runs.rl_games_layout import RlGamesTags
from rlchain.runs.run_dir import create_run_dir
from rlchain.runs.writers import WandbWriter, check_writer_names, make_writers
from rlchain.training.loop import Loop

log = get_logger(__name__)


@dataclass(frozen=True)
class BuiltRun:
    """What :meth:`Runner._train` built for one run, in one pass: the algorithm class, its env, the model
    (with the checkpoint's weights when resuming), the checkpoint read (``state``) and this process's
    device, seed, torchrun group and thread plan."""

    params: Params
    algorithm: Any
    env: Any
    model: Any
    device: Any
    seed: int
    state: dict[str, Any] | None
    checkpoint: str | None
    group: Any
    threads: ThreadPlan | None


@dataclass(frozen=True)
class TrainOptions:
    """The caller's choices for a training run beyond the config (``Runner.train``'s arguments)."""

    sigma: float | None
    callbacks: list[Any]
    track: bool
    wandb_project: str
    wandb_entity: str | None


class Runner:
    """Holds one validated config and runs training or playing with it."""

    def __init__(self) -> None:
        self.raw: dict[str, Any] | None = None
        self.params: Params | None = None
        self.layout = "rlchain"
        """``rl_games`` (set by rl_games' API, :mod:`rlchain.rl_games`): checkpoint names, extra tags and the
        frame axis as rl_games writes them (:mod:`rlchain.runs.rl_games_layout`)."""

    def load(self, config: str | dict[str, Any], overrides: list[str] | None = None,
             source: str | None = None) -> Runner:
        """Load a YAML/JSON path, a packaged config's name (``ppo_cartpole``, rlchain.config.packaged) or
        an already-read dict (``{'params': ...}``) and validate it. ``source``: what a dict's config errors name
        as their file (what the user wrote it as: a face's ``PPOConfig``; ``<dict>`` by default)."""
        if isinstance(config, str):
            source = resolve_config(config)
            raw = load_raw(source)
        else:
            source, raw = source or "<dict>", copy.deepcopy(config)
        translated = is_embodichain(raw)
        raw, rest = from_embodichain(raw, overrides or [], source)
        if translated and os.environ.get("RANK", "0") == "0":  # once under torchrun
            log.info("EmbodiChain config read as this rl_games-style config (saved as the run folder's config):\n"
                     + yaml.safe_dump(raw, sort_keys=False).rstrip())
        raw = apply_overrides(raw, rest, source)
        import_user_modules(raw, source)  # first: they register the networks / algos the parser looks up
        self.params = on_available_device(parse_params(raw, source))  # no GPU: the run is a device: cpu run
        self.raw = raw
        return self

    def load_from_checkpoint(self, path: str, overrides: list[str] | None = None,
                             state: dict[str, Any] | None = None) -> Runner:
        """Use the resolved config stored inside a checkpoint (for --play without --file).
        A shipped checkpoint's name (``cartpole``) works. ``state``: the checkpoint as the caller read it already
        (so a caller that loads the weights too reads the file once)."""
        path = locate_checkpoint(path)[0]
        state = ckpt.load(path) if state is None else state
        config = state.get("config")
        if not isinstance(config, dict) or not isinstance(config.get("params"), dict):
            raise ckpt.CheckpointError(f"{path}: the checkpoint holds no config (no 'config' with 'params'); "
                                       f"pass the config it was trained with: --file cfg.yaml")
        # the file's config is data: no module, callback, watched folder or trust from it (the user's
        # overrides, applied after, may set them on purpose)
        stored, dropped = as_data({"params": config["params"]}, path)
        if dropped:
            warnings.warn(f"{path}: the checkpoint's {', '.join(dropped)} not used (a checkpoint's config gives "
                          f"shapes and hyperparameters only; pass your config with --file to use them)",
                          stacklevel=2)
        if "config_format" not in state:  # a pre-release rlchain stored its input file's dict
            raise ckpt.CheckpointError(f"{path}: the checkpoint has no 'config_format' (written by a pre-release "
                                       f"rlchain); pass the config it was trained with: --file cfg.yaml")
        if state["config_format"] != CONFIG_FORMAT:
            raise ckpt.CheckpointError(f"{path}: config format '{state['config_format']}' is not this "
                                       f"rlchain's '{CONFIG_FORMAT}'; pass the config it was trained with: "
                                       f"--file cfg.yaml")
        raw = apply_overrides(stored, overrides or [], path)
        check_stored_env(raw["params"].get("config"), path, stored_by(stored, overrides or []))  # before any env
        import_user_modules(raw, path)
        self.params = on_available_device(params_from_state(raw["params"], path))
        self.raw = raw
        return self

    def train(self, checkpoint: str | None = None, seed: int | None = None, sigma: float | None = None,
              callbacks: list[Any] | None = None, track: bool = False, wandb_project: str = "rlchain",
              wandb_entity: str | None = None) -> Any:
        """Train (resuming from ``checkpoint`` when given); returns a TrainResult.

        ``track`` logs the scalars (TensorBoard tags) and the config to Weights & Biases. Under torchrun
        with ``multi_gpu: True`` every rank calls this; rank 0 alone writes the run folder.
        """

        params = self._require()
        if checkpoint is not None:
            checkpoint = locate_checkpoint(checkpoint)[0]
        seed = seed if seed is not None else params.seed
        if seed is not None and check_seed(seed):
            raise ConfigError(params.source, "--seed", check_seed(seed))
        group = distributed.setup(params, self.raw, seed)  # None unless launched by torchrun (multi_gpu)
        try:
            with ckpt.trusting(params.config.trust_checkpoint):  # the resume file and a distillation teacher
                result = self._train(params, group, checkpoint, seed, sigma, callbacks or [], track,
                                     wandb_project, wandb_entity)
        except BaseException as exc:
            distributed.shutdown(group, clean=False)
            lost = distributed.collective_failure(group, exc)  # a dead peer: one line (by type), not a traceback
            if lost is not None and lost is not exc:
                raise lost from exc
            raise
        distributed.shutdown(group, clean=not result.stop_reason.startswith("interrupted"))
        return result

    def _train(self, params: Params, group: Any, checkpoint: str | None, seed: int | None, sigma: float | None,
               callbacks: list[Any], track: bool, wandb_project: str, wandb_entity: str | None) -> Any:
        """Build the run once -- this process's context, the algorithm (looked up once), its env, its check
        (once), the model with the checkpoint's weights (read and loaded once) -- then train it."""

        run_ctx: ProcessContext = resolve(params, seed, group)  # device, seed (per rank), printing
        params, seed = run_ctx.params, run_ctx.seed
        cfg = params.config
        seed_everything(seed)
        threads = set_threads(params.torch_threads, params.update_threads, cfg.device,
                              group.local_world_size if group is not None else 1)
        tune_malloc(params.malloc)  # freed tensors reused, not fresh pages from the kernel every epoch
        state = ckpt.load(checkpoint) if checkpoint else None
        device = resolve_device(cfg.device)
        algorithm = algorithm_class(params)
        env = algorithm.build_training_env(params, seed)  # the vectorized env; APPO: its runners
        threads = for_env(threads, env, params.torch_threads)  # tensor envs: rollout threads as the update's
        try:
            algorithm.check_config(params, env_spec(env))  # before the model (PPO: the minibatch)
            with communicator.building_with(group or communicator.SINGLE):  # normalizers sync over ranks
                model = build_model(params, env, device)
            if state is not None:  # a mismatched checkpoint fails before any run folder exists
                ckpt.load_model_state(model, state, checkpoint)
            if group is not None:  # so do ranks with different envs or resume points (torchrun)
                group.check_consistent(env, model, state)
            built = BuiltRun(params, algorithm, env, model, device, seed, state, checkpoint, group, threads)
            return self._train_in_run_dir(built, TrainOptions(sigma, callbacks, track, wandb_project, wandb_entity))
        finally:
            env.close()

    def _train_in_run_dir(self, built: BuiltRun, options: TrainOptions) -> Any:
        params, group, model, state, checkpoint = built.params, built.group, built.model, built.state, built.checkpoint
        cfg = params.config
        main = group is None or group.is_main  # under torchrun only rank 0 writes folders, logs and checkpoints
        check_writer_names(cfg.log_writers, params.source)  # before a run folder exists
        layout = self.layout if self.layout != "rlchain" else cfg.checkpoint_names
        run = create_run_dir(cfg.train_dir, cfg.name, cfg.full_experiment_name, self.raw, layout) if main else None
        writers = make_writers(cfg.log_writers, run.root, params.source) if run is not None else []
        tracker = None
        if options.track and run is not None:  # a log writer like the others: wandb.log of the tagged scalars
            tracker = WandbWriter(options.wandb_project, options.wandb_entity,
                                  {**self.raw, "run": {"seed": built.seed}}, os.path.basename(run.root), run.summaries)
            writers.append(tracker)
        ok = False
        logger = TrainLogger(run.summaries if run is not None else None, cfg.print_stats, writers=writers,
                             progress=cfg.progress, rl_games=rl_games_tags(cfg) if self.layout == "rl_games" else None)
        trainer = None
        try:
            extra = {"comm": group} if group is not None else {}  # the Communicator its agents sync through
            with communicator.building_with(group or communicator.SINGLE):  # Loop.create: no leak on failure
                trainer = Loop.create(params, built.algorithm, built.env, model, built.device, run, logger,
                                      built.seed, self.raw, checked=True, resuming=state is not None,
                                      threads=built.threads, **extra)
            if state is not None:
                trainer.restore(state, checkpoint)
            if options.sigma is not None:
                apply_sigma(model, options.sigma)
            if group is not None:  # every rank starts from rank 0's state
                trainer.join_ranks()
            trainer.events.extend(options.callbacks)
            if cfg.print_stats:
                verb, origin = ("resuming", f" from {checkpoint} at epoch {trainer.ctx.epoch}") if state \
                    else ("training", "")
                log.info(f"rlchain: {verb} {params.algo.name} on {cfg.env_name}{origin} ({built.env.num_envs} envs, "
                         f"device {built.device}, seed {built.seed}) -> {run.root}")
            result = trainer.train()
            ok = True
            return result
        finally:  # on every exit path (an env error, a divergence, KeyboardInterrupt): the eval env too
            if trainer is not None:
                trainer.close()
            if tracker is not None:
                tracker.exit_code = 0 if ok else 1
            logger.close()

    def export(self, checkpoint: str, output: str | None = None, policy: str | None = None) -> str | list[str]:
        """Export the checkpoint's deterministic policy to ONNX (with a parity check); returns the path.
        With ``config.multi_agent``: one graph per policy (only ``policy`` when given); returns the paths.
        A shipped checkpoint's name (``cartpole``) works; its default output is ``<name>.onnx`` here."""

        params = self._require()
        checkpoint, packaged = locate_checkpoint(checkpoint)
        if packaged and output is None:  # next to the shipped file is inside the installed package
            output = os.path.splitext(os.path.basename(checkpoint))[0] + ".onnx"
        with ckpt.trusting(params.config.trust_checkpoint):
            if params.policies is not None:
                return export_policies(params, checkpoint, output, policy)
            if policy is not None:
                raise ConfigError(params.source, "--policy", "applies to configs with config.multi_agent only")
            return export_from_cli(self, checkpoint, output)

    def play(self, checkpoint: str | None, games: int | None = None, deterministic: bool | None = None,
             sigma: float | None = None, quiet: bool = False) -> Any:
        """Play with the Player (a shipped checkpoint by name too: ``cartpole``); returns a PlayResult."""

        params = self._require()
        if checkpoint is not None:
            checkpoint = locate_checkpoint(checkpoint)[0]
        elif not params.config.player.evaluation:
            warnings.warn("no checkpoint: playing an untrained (freshly initialized) policy", stacklevel=2)
        # the rollout's threads as training (2 threads on 2 busy cores cost 30x); no update, so no core sample
        set_threads(params.torch_threads, None, params.config.device, updates=False)
        with ckpt.trusting(params.config.trust_checkpoint):
            if params.policies is not None:  # config.multi_agent: every policy plays its agents
                return play_policies(params, checkpoint, games, deterministic, quiet)
            player = Player(params, checkpoint, sigma=sigma)
        try:
            return player.play(games=games, deterministic=deterministic, quiet=quiet)
        finally:
            player.close()

    def record(self, checkpoint: str | None, video_dir: str, games: int = 1, deterministic: bool = True) -> list[str]:
        """Record ``games`` episodes of the checkpoint's policy to mp4 files in ``video_dir`` (single-policy
        configs); returns their paths. A shipped checkpoint's name works."""
        params = self._require()
        if params.policies is not None:
            raise ConfigError("", "--video", "records single-policy configs only (not config.multi_agent yet)")
        if checkpoint is not None:
            checkpoint = locate_checkpoint(checkpoint)[0]
        with ckpt.trusting(params.config.trust_checkpoint):
            return record_episodes(params, checkpoint, video_dir, games=games, deterministic=deterministic)

    def _require(self) -> Params:
        if self.params is None:
            raise RuntimeError("call Runner.load(config) first")
        return self.params


MULTI_POLICY = {APPO: MultiPolicyAPPO, IMPALA: MultiPolicyIMPALA}
"""The multi-policy learner of each registered algorithm that takes ``config.multi_agent`` (else PPO's)."""


def algorithm_class(params: Params) -> Any:
    """The registered algorithm of ``params.algo.name`` (multi-policy PPO with ``config.multi_agent``)."""
    if params.policies is not None:  # config.multi_agent: one learner per policy
        if params.algo.name in AGENTS:  # DQN / SAC
            return MultiPolicyOffPolicy
        return MULTI_POLICY.get(ALGOS.get(params.algo.name), MultiPolicyPPO)
    return ALGOS.get(params.algo.name)


def rl_games_tags(cfg: Any) -> RlGamesTags:
    """What rl_games' extra tags read of a run's config (PPO's e_clip; the reward shaper)."""
    rs = cfg.reward_shaper
    affine = not rs.log_val and rs.min_val == float("-inf") and rs.max_val == float("inf")
    return RlGamesTags(getattr(cfg, "e_clip", None), float(rs.scale_value), float(rs.shift_value), affine)


def stored_by(stored: dict[str, Any], overrides: list[str]) -> Any:
    """Whether a key under ``params.config`` (``env_config.env``) still holds the stored config's value: set in
    ``stored`` and by no override (``params.config.env_config.env=...`` or a block above it)."""
    given = [o.split("=", 1)[0].strip() for o in overrides if "=" in o]
    given = [g if g.split(".")[0] == "params" else f"params.{g}" for g in given]  # 'params.' is optional
    config = stored["params"].get("config")

    def from_file(key: str) -> bool:
        full = f"params.config.{key}"
        if any(full == g or full.startswith(g + ".") for g in given):
            return False
        node: Any = config
        for part in key.split("."):
            if not isinstance(node, dict) or part not in node:
                return False
            node = node[part]
        return True

    return from_file


def locate_checkpoint(name_or_path: str) -> tuple[str, bool]:
    """Where a ``--checkpoint`` / ``checkpoint=`` is: a path as given, or a shipped checkpoint by name
    (``cartpole``); whether it is a shipped one. A bare word that is neither but close to a shipped name is a
    CheckpointError with a did-you-mean. Every Runner method that takes a checkpoint resolves it here."""
    path, packaged = resolve_checkpoint(name_or_path)
    if not (os.path.exists(path) or "/" in path or os.sep in path):
        hint = did_you_mean(os.path.splitext(path)[0], checkpoint_names())
        if hint:
            raise ckpt.CheckpointError(f"{path}: checkpoint not found, and no shipped checkpoint has that "
                                       f"name{hint}")
    return path, packaged
