"""The Ray Tune trainable: one rlchain run per trial, one epoch per Tune step (imports Ray).

Each ``step`` trains one epoch through :class:`rlchain.tuning.epochs.EpochStepper` and reports its
metrics (mean reward, frames, fps, losses, the live hyperparameters as ``hp/<name>``). Checkpoints
are rlchain checkpoints (exact resume state) plus ``trial.json`` (the trial, its values, the
schedule it followed), so Tune's pause/resume, PBT's exploit and the restart of a crashed trial
(``FailureConfig``) all go through :meth:`Loop.restore`. With ``reuse_actors`` an exploit loads the
better trial's checkpoint into the running envs and sets the perturbed values through the Loop's
``set_params``: PBT's explore step never restarts the envs.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import shutil
import zlib
from dataclasses import dataclass, field
from typing import Any

from ray import tune

from rlchain.config.resolve import with_config
from rlchain.runner import Runner
from rlchain.tuning.common import override_strings
from rlchain.tuning.epochs import EpochStepper

CHECKPOINT = "rlchain.pth"
TRIAL_JSON = "trial.json"


@dataclass
class TrialSetup:
    """What every trial of a search shares (sent to the workers once)."""

    base: dict  # the base config as read by the driver: trials on other nodes need no copy of the file
    overrides: list[str]  # the search's overrides, train_dir and stop keys
    keys: list[str]  # the searched / mutated config keys
    live: dict[str, str] = field(default_factory=dict)  # config key -> tunable name (set_params)
    seed: int = 0  # trial seed = seed + the trial's index
    envpool: bool = False  # give envpool the trial's CPUs as threads
    worst: float = -math.inf  # the metric until the first episode ends (-inf when maximizing)


def trial_seed(setup: TrialSetup, trial_id: str, dirname: str = "") -> int:
    """The trial's seed: the search's seed plus the trial's index.

    The index is read from Ray's trial folder name (``RlchainTrainable_3e5c299c_4_params...`` -> 4), or from a
    trial id that ends in one (``<experiment>_00003`` -> 3). Ray 2.x trial ids are hex with no index: without a
    folder name they get a stable number from the id, so trials never share a seed (with every trial on one
    seed, exact resume made the trials of a FIFO search identical)."""
    found = re.search(rf"_{re.escape(trial_id)}_(\d+)(?:_|$)", dirname) if dirname else None
    if found:
        return setup.seed + int(found.group(1))
    tail = trial_id.rsplit("_", 1)[-1]
    if tail.isdigit():
        return setup.seed + int(tail)
    return setup.seed + zlib.crc32(trial_id.encode()) % 100_000


def thread_overrides(params: Any, cpus: int, envpool: bool) -> Any:
    """The trial's Params: torch (and envpool) threads from the CPUs Ray gave the trial, unless the config
    set fewer (a new value; ``params`` is frozen)."""
    if envpool:
        env_config = dict(params.config.env_config)
        env_config["num_threads"] = min(int(env_config.get("num_threads") or cpus), cpus)
        params = with_config(params, env_config=env_config)
        rollout = max(1, cpus // 2)  # envpool's threads share the cores while the policy acts
    else:
        rollout = cpus
    return dataclasses.replace(params, torch_threads=min(params.torch_threads or rollout, cpus),
                               update_threads=min(params.update_threads or cpus, cpus))


class RlchainTrainable(tune.Trainable):
    """A trial: the base config with the trial's values, trained epoch by epoch."""

    def setup(self, config: dict, setup: TrialSetup) -> None:
        self.info = setup
        self.values = {k: config[k] for k in setup.keys if k in config}
        self.stepper: Any = None
        self.run_trial = ""  # the trial whose run folder the live run writes
        self.lineage: list[list[Any]] = []  # [[epochs done, {name: value}], ...]: the schedule followed
        self.note: dict[str, Any] = {}  # restore / exploit facts for the next result
        self.fresh = False  # reset for another trial and no checkpoint loaded yet
        self.last: dict[str, Any] = {}

    # ----- Tune's hooks --------------------------------------------------------------------
    def step(self) -> dict[str, Any]:
        if self.fresh and self.stepper is not None:  # a reused actor starts a new trial from scratch
            self._close()
        self.fresh = False
        if self.stepper is None:
            self._build(None)
        report = self.stepper.next_epoch()
        if report is None:  # the run's own stop rule (max_frames, max_epochs) came
            return {**self.last, "done": True}
        fps = self._frames_per_epoch() / max(report.seconds, 1e-9)
        result: dict[str, Any] = {
            "epoch": report.epoch, "frames": report.frames, "timesteps_total": report.frames, "fps": fps,
            "epoch_seconds": report.seconds,
            "exploited_from": self.note.get("exploited_from", ""),
            "restored_epoch": self.note.get("restored_epoch", -1),
        }
        # until an episode ends there is no reward: the worst value, so schedulers rank the trial last
        finished = report.mean_reward is not None and math.isfinite(report.mean_reward)
        result["mean_reward"] = report.mean_reward if finished else self.info.worst
        result["mean_length"] = report.mean_length if finished else 0.0
        result["best_reward"] = report.best_reward if math.isfinite(report.best_reward) else self.info.worst
        for name, value in report.stats.items():
            result[f"losses/{name}" if "/" not in name else name] = value
        for name, value in report.params.items():
            result[f"hp/{name}"] = value
        if self.note.get("exploit"):
            result["exploit"] = json.dumps(self.note["exploit"])
        self.note = {}
        self.last = result
        return result

    def save_checkpoint(self, checkpoint_dir: str) -> None:
        path = os.path.join(checkpoint_dir, CHECKPOINT)
        if self.stepper is not None and self.stepper.context is not None:
            self.stepper.save(path)
            epoch = self.stepper.context.state.epoch
        elif self.stepper is not None and self.stepper.checkpoint:  # restored, not stepped yet
            shutil.copyfile(self.stepper.checkpoint, path)
            epoch = self.lineage[-1][0] if self.lineage else 0
        else:
            raise RuntimeError("nothing to checkpoint before the first epoch")
        with open(os.path.join(checkpoint_dir, TRIAL_JSON), "w", encoding="utf-8") as fh:
            json.dump({"trial_id": self.trial_id, "epoch": epoch, "values": self.values,
                       "lineage": self.lineage}, fh)

    def load_checkpoint(self, checkpoint_dir: str) -> None:
        with open(os.path.join(checkpoint_dir, TRIAL_JSON), encoding="utf-8") as fh:
            data = json.load(fh)
        epoch = int(data["epoch"])
        donor = data["trial_id"]
        self.fresh = False
        self.lineage = [entry for entry in data["lineage"] if entry[0] <= epoch]
        live = self._live_values()
        if not self.lineage or self.lineage[-1][1] != live:
            self.lineage.append([epoch, live])
        self.note = {"restored_epoch": epoch}
        if donor != self.trial_id:  # PBT exploit: another trial's weights, this trial's (perturbed) values
            before = {k: v for k, v in data["values"].items() if k in self.info.live}
            after = {k: v for k, v in self.values.items() if k in self.info.live}
            self.note.update(exploited_from=donor, exploit={"from": donor, "epoch": epoch, "before": before,
                                                            "after": after})
        # Tune may delete its checkpoint folder once restored: keep the file with the trial
        local = os.path.join(self.logdir, f"restore_{CHECKPOINT}")
        shutil.copyfile(os.path.join(checkpoint_dir, CHECKPOINT), local)
        if self.stepper is not None and self.stepper.result is not None:  # that run ended: start anew
            self._close()
        if self.stepper is None:
            self._build(local)
            return
        if self.run_trial != self.trial_id:
            self.stepper.move_run(f"trial_{self.trial_id}")
            self.run_trial = self.trial_id
        self.stepper.load(local)
        self.stepper.set_params(live)

    def reset_config(self, new_config: dict) -> bool:
        """Reuse this actor (and its envs) for another trial or a perturbed config: only when every
        changed value can change live; a checkpoint (Tune calls load_checkpoint next) or, for a new
        trial, a fresh run follows."""
        values = {k: new_config[k] for k in self.info.keys if k in new_config}
        changed = [k for k in set(values) | set(self.values) if values.get(k) != self.values.get(k)]
        if any(k not in self.info.live for k in changed):
            return False
        self.values = values
        self.fresh = True
        self.note = {}
        self.last = {}
        return True

    def cleanup(self) -> None:
        self._close()

    # ----- helpers -------------------------------------------------------------------------
    def _live_values(self) -> dict[str, float]:
        return {self.info.live[k]: v for k, v in self.values.items() if k in self.info.live}

    def _build(self, checkpoint: str | None) -> None:
        import ray


        overrides = list(self.info.overrides) + override_strings(self.values) + [
            f"params.config.full_experiment_name=trial_{self.trial_id}"]
        runner = Runner().load(self.info.base, overrides)  # a dict: the Runner copies it
        cpus = int(ray.get_runtime_context().get_assigned_resources().get("CPU", 1) or 1)
        # Tune's stop rule replaces score_to_win; restored counters keep the others
        runner.params = thread_overrides(with_config(runner.params, score_to_win=math.inf), max(1, cpus),
                                         self.info.envpool)
        live = self._live_values()
        if checkpoint is None:
            self.lineage = [[0, live]]
        self.stepper = EpochStepper(runner, checkpoint=checkpoint, live=live,
                                    seed=trial_seed(self.info, self.trial_id, self._trial_dirname()))
        self.run_trial = self.trial_id

    def _trial_dirname(self) -> str:
        """Ray's folder name of this trial (it holds the trial's index), or "" where Ray does not say."""
        storage = getattr(self, "_storage", None)
        name = getattr(storage, "trial_dir_name", None) if storage is not None else None
        return str(name or os.path.basename(str(getattr(self, "_logdir", "") or "")))

    def _frames_per_epoch(self) -> int:
        context = self.stepper.context if self.stepper is not None else None
        return int(context.frames_per_epoch()) if context is not None else 0

    def _close(self) -> None:
        if self.stepper is not None:
            self.stepper.shutdown()
        self.stepper = None
