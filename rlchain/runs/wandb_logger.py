"""``--track``: mirror the TensorBoard scalars of a training run to Weights & Biases.

rlchain does not log to wandb itself: :class:`~rlchain.runs.logging.TrainLogger` writes its
rl_games TensorBoard tags, and wandb's ``sync_tensorboard`` reads the event files it writes, so
the W&B charts have the same names (``rewards/step``, ``losses/a_loss``, ...).

Order matters: :func:`start_wandb` must run *before* the ``SummaryWriter`` (TrainLogger) is
created -- wandb finds the event files by patching TensorBoard's writer class -- and
:meth:`WandbRun.finish` *after* the writer is closed, so the last scalars are read::

    tracker = start_wandb(project, entity, raw_config, run_name, run.summaries)
    logger = TrainLogger(run.summaries, ...)
    try:
        ...train...
    finally:
        logger.close()
        tracker.finish()

Offline: ``WANDB_MODE=offline`` writes ``<dir>/wandb/offline-run-*`` (upload later with
``wandb sync``). Requires ``pip install rlchain[wandb]``.
"""

from __future__ import annotations

import os
from typing import Any

INSTALL_HINT = "--track needs Weights & Biases: pip install rlchain[wandb]"


class TrackingError(RuntimeError):
    """wandb is installed but the run could not start (not logged in, bad entity, ...)."""


def _import_wandb() -> Any:
    try:
        import wandb
    except ImportError:
        raise ImportError(INSTALL_HINT) from None
    return wandb


class WandbRun:
    """The started wandb run; ``finish()`` ends it and removes the TensorBoard patch.

    Other attributes (``id``, ``dir``, ``url``, ``config``, ...) are the wandb run's.
    """

    def __init__(self, wandb: Any, run: Any) -> None:
        self._wandb = wandb
        self.run = run
        self.finished = False

    def finish(self, exit_code: int | None = None) -> None:
        """Flush the last TensorBoard events and end the run (idempotent). Call after the writer is closed."""
        if self.finished:
            return
        self.finished = True
        try:
            self.run.finish(exit_code=exit_code)
        finally:
            _unpatch_tensorboard(self._wandb)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.run, name)

    def __enter__(self) -> WandbRun:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        self.finish(exit_code=None if exc_type is None else 1)


def _unpatch_tensorboard(wandb: Any) -> None:
    if wandb.patched.get("tensorboard"):
        wandb.tensorboard.unpatch()


def start_wandb(project: str, entity: str | None, config_dict: dict[str, Any], run_name: str,
                summaries_dir: str, wandb_dir: str | None = None) -> WandbRun:
    """Start a wandb run that mirrors the TensorBoard scalars written under ``summaries_dir``.

    ``config_dict``: the run's config (e.g. ``Runner.raw``), shown as the run's config in W&B.
    ``wandb_dir``: where wandb keeps its files (``<dir>/wandb/...``); default ``$WANDB_DIR`` when
    set, else the parent of ``summaries_dir`` (the rlchain run folder). Call before the
    SummaryWriter is created; see the module docstring. Raises ImportError (install hint) when
    wandb is missing and :class:`TrackingError` when ``wandb.init`` fails.
    """
    wandb = _import_wandb()
    summaries_dir = os.path.abspath(summaries_dir)
    os.makedirs(summaries_dir, exist_ok=True)
    wandb_dir = wandb_dir or os.environ.get("WANDB_DIR") or os.path.dirname(summaries_dir)
    os.makedirs(wandb_dir, exist_ok=True)
    # An explicit root: the tags keep their names (no folder prefix) and wandb does not wait
    # 10 s at finish() to guess the root directory. sync_tensorboard=True then finds it patched.
    _unpatch_tensorboard(wandb)
    wandb.tensorboard.patch(root_logdir=summaries_dir)
    try:
        run = wandb.init(project=project, entity=entity, config=config_dict, name=run_name,
                         sync_tensorboard=True, dir=wandb_dir)
    except BaseException as exc:
        _unpatch_tensorboard(wandb)
        if isinstance(exc, wandb.errors.Error):
            raise TrackingError(f"--track: wandb.init failed: {' '.join(str(exc).split())} "
                                f"(run `wandb login`, or set WANDB_MODE=offline)") from None
        raise
    return WandbRun(wandb, run)
