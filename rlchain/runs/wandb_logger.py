"""``--track``: a Weights & Biases run for a training run.

:func:`start_wandb` starts it (project, entity, the config, the folder wandb keeps its files in, one-line
errors); :class:`rlchain.runs.writers.WandbWriter` then logs every scalar of the run to it with
``wandb.log``, under the rl_games TensorBoard tags (``rewards/step``, ``losses/a_loss``, ...), and
finishes it when the run ends. TensorBoard is not patched: the two writers are independent.

Offline: ``WANDB_MODE=offline`` writes ``<dir>/wandb/offline-run-*`` (upload later with
``wandb sync``). Requires ``pip install rlchain[wandb]``.
"""

from __future__ import annotations

import os
from typing import Any

from rlchain.errors import optional_import

INSTALL_HINT = "--track needs Weights & Biases: pip install rlchain[wandb]"


class TrackingError(RuntimeError):
    """wandb is installed but the run could not start (not logged in, bad entity, ...)."""


def _import_wandb() -> Any:
    return optional_import("wandb", INSTALL_HINT)


class WandbRun:
    """The started wandb run; ``finish()`` ends it (once). ``wandb_run`` is wandb's own run object
    (``log``, ``id``, ``dir``, ``url``, ``config``, ...).
    """

    def __init__(self, wandb: Any, run: Any) -> None:
        self._wandb = wandb
        self.wandb_run = run
        self.finished = False

    def finish(self, exit_code: int | None = None) -> None:
        """End the run (idempotent)."""
        if self.finished:
            return
        self.finished = True
        self.wandb_run.finish(exit_code=exit_code)

    def __enter__(self) -> WandbRun:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        self.finish(exit_code=None if exc_type is None else 1)


def start_wandb(project: str, entity: str | None, config_dict: dict[str, Any], run_name: str,
                summaries_dir: str, wandb_dir: str | None = None) -> WandbRun:
    """Start the wandb run of the training run whose TensorBoard folder is ``summaries_dir``.

    ``config_dict``: the run's config (e.g. ``Runner.raw``), shown as the run's config in W&B.
    ``wandb_dir``: where wandb keeps its files (``<dir>/wandb/...``); default ``$WANDB_DIR`` when
    set, else the parent of ``summaries_dir`` (the rlchain run folder). Raises ImportError (install hint) when
    wandb is missing and :class:`TrackingError` when ``wandb.init`` fails.
    """
    wandb = _import_wandb()
    summaries_dir = os.path.abspath(summaries_dir)
    os.makedirs(summaries_dir, exist_ok=True)
    wandb_dir = wandb_dir or os.environ.get("WANDB_DIR") or os.path.dirname(summaries_dir)
    os.makedirs(wandb_dir, exist_ok=True)
    try:
        run = wandb.init(project=project, entity=entity, config=config_dict, name=run_name, dir=wandb_dir)
    except BaseException as exc:
        if isinstance(exc, wandb.errors.Error):
            raise TrackingError(f"--track: wandb.init failed: {' '.join(str(exc).split())} "
                                f"(run `wandb login`, or set WANDB_MODE=offline)") from None
        raise
    return WandbRun(wandb, run)
