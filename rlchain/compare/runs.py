"""Run folders -> curves: the TensorBoard scalars rlchain wrote, against frames and against seconds.

A run folder is what ``--train`` makes: ``<train_dir>/<name>_<dd-HH-MM-SS>/`` with ``config.yaml`` and
``summaries/events.out.tfevents.*`` (rl_games' layout; an rl_games run folder reads the same). Every
scalar rlchain writes per epoch is logged at x = env frames (rlchain/runs/writers.py ``Step.x``):
``rewards/step`` (mean reward of the last ``games_to_track`` episodes), ``episodes/success_rate``,
``env_info/<key>`` (``log_info_keys``), ``losses/*`` ... Its seconds are the event's wall time less the
run's first event (the writer opening, just before training starts), so a curve against seconds counts
the run's own training time, startup of the envs and model included, like ``rewards/time``.

Grouping (:func:`group_runs`): by the argument each run came from (``--label-by glob``; an argument
``LABEL=PATTERN`` names its group), by the run folder's name without its date-time suffix (``name``), or
by ``params.config.name`` in the run's ``config.yaml`` (``config``).
"""

from __future__ import annotations

import glob
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from rlchain.compare.files import CompareError, read_config, scalar_events, walk_files

REWARD = "rewards/step"
SUCCESS = "episodes/success_rate"
TAG_ALIASES = {"reward": REWARD, "rewards": REWARD, "success": SUCCESS, "success_rate": SUCCESS}
DATE_SUFFIX = re.compile(r"_\d{2}-\d{2}-\d{2}-\d{2}(_\d+)?$")  # create_run_dir's _%d-%H-%M-%S[_pid]
LABEL_BY = ("name", "config", "glob")


@dataclass(frozen=True)
class Curve:
    """One scalar of one run: its values at env ``frames`` and at ``seconds`` since the run started.

    ``frames_end`` / ``seconds_end``: how far the run went, when it is known to have gone on past its last
    point (a benchmark run stopped at a time budget); by default its last point."""

    frames: np.ndarray
    seconds: np.ndarray
    values: np.ndarray
    frames_end: float | None = None
    seconds_end: float | None = None

    def axis(self, name: str) -> np.ndarray:
        """The x values on ``name`` (``frames`` or ``seconds``)."""
        if name not in ("frames", "seconds"):
            raise ValueError(f"axis must be frames or seconds, got {name!r}")
        return self.frames if name == "frames" else self.seconds

    def end(self, axis: str) -> float:
        """How far the run went on ``axis``."""
        explicit = self.frames_end if axis == "frames" else self.seconds_end
        xs = self.axis(axis)
        return float(explicit) if explicit is not None else float(xs[-1]) if xs.size else 0.0

    def value_at(self, x: float, axis: str = "frames") -> float | None:
        """The last value reported at or before ``x``; None before the first one or past the run's end
        (a run that ended earlier has no value there)."""
        xs = self.axis(axis)
        if xs.size == 0 or x < xs[0] or x > self.end(axis):
            return None
        return float(self.values[int(np.searchsorted(xs, x, side="right")) - 1])


@dataclass
class Run:
    """One run folder: where it is, its label (group), its config name and its curves by tag."""

    path: str
    label: str
    config_name: str
    curves: dict[str, Curve] = field(default_factory=dict)

    @property
    def name(self) -> str:
        return os.path.basename(os.path.normpath(self.path))


def curve_from_events(events: Sequence[Sequence[float]], seconds_end: float | None = None,
                      frames_end: float | None = None) -> Curve:
    """A Curve from ``(seconds, frames, value)`` rows (benchmarks/peers/curves.py's saved runs), sorted by frames;
    ``seconds_end`` / ``frames_end``: the run went on until then (its time budget)."""
    rows = sorted(events, key=lambda e: (e[1], e[0]))
    array = np.asarray(rows, dtype=float).reshape(-1, 3)
    return Curve(frames=array[:, 1], seconds=array[:, 0], values=array[:, 2], frames_end=frames_end,
                 seconds_end=seconds_end)


def event_files(path: str) -> list[str]:
    """The TensorBoard event files under ``path`` (``events.out.tfevents.*``), folder by folder."""
    return [f for f in walk_files(path) if os.path.basename(f).startswith("events.out.tfevents.")]


def read_curves(path: str, tags: Sequence[str] | None = None) -> dict[str, Curve]:
    """Every scalar tag (or those in ``tags``) of the run folder ``path``, as Curves against frames and
    against seconds since its first event. CompareError when it has no event files, or one that is refused
    (:mod:`rlchain.compare.files`: a special file, a damaged record)."""
    files = event_files(path)
    if not files:
        raise CompareError(f"{path}: no TensorBoard event files (events.out.tfevents.*) in it or its "
                           f"summaries/: not a run folder, or the run wrote nothing yet")
    rows: dict[str, list[tuple[float, float, float]]] = {}
    start = None
    for file in files:
        first, scalars = scalar_events(file, None if tags is None else set(tags))
        if first is None:  # an empty event file
            continue
        start = first if start is None else min(start, first)
        for tag, wall, step, value in scalars:
            rows.setdefault(tag, []).append((wall, step, value))
    if start is None:
        raise CompareError(f"{path}: its event files hold no events")
    return {tag: curve_from_events([(w - start, step, value) for w, step, value in events])
            for tag, events in rows.items()}


def config_name(path: str) -> str:
    """``params.config.name`` of the run's ``config.yaml`` ('' when there is none); CompareError (one line) for a
    config.yaml that is refused (:func:`rlchain.compare.files.read_config`)."""
    raw = read_config(os.path.join(path, "config.yaml"))
    try:
        return str(raw["params"]["config"].get("name", ""))
    except (KeyError, TypeError, AttributeError):
        return ""


def name_label(path: str) -> str:
    """The run folder's name without create_run_dir's ``_dd-HH-MM-SS`` suffix: the seeds of one config share it."""
    return DATE_SUFFIX.sub("", os.path.basename(os.path.normpath(path)))


def _is_run(path: str) -> bool:
    """A run folder: it has ``summaries/`` or event files of its own."""
    return os.path.isdir(os.path.join(path, "summaries")) or \
        bool(glob.glob(os.path.join(path, "events.out.tfevents.*")))


def expand(argument: str) -> list[str]:
    """The run folders an argument names: a glob (or a plain path); a folder that is no run folder but holds
    run folders (a ``train_dir`` such as ``runs/``) stands for them."""
    matches = sorted(glob.glob(argument)) if glob.has_magic(argument) else [argument]
    folders: list[str] = []
    for match in matches:
        if not os.path.isdir(match):
            continue
        if _is_run(match):
            folders.append(match)
        else:
            inner = sorted(os.path.join(match, d) for d in os.listdir(match) if _is_run(os.path.join(match, d)))
            folders.extend(inner or [match])  # a folder without runs: read_curves says what is missing
    return folders


def split_label(argument: str) -> tuple[str | None, str]:
    """``LABEL=PATTERN`` -> (LABEL, PATTERN); a plain pattern -> (None, pattern)."""
    label, sep, pattern = argument.partition("=")
    if sep and label and os.sep not in label and not os.path.exists(argument):
        return label, pattern
    return None, argument


def group_runs(arguments: Sequence[str], label_by: str = "name") -> list[tuple[str, str]]:
    """``(label, run folder)`` for every run the arguments name, in argument order, each folder once.

    ``label_by``: ``glob`` (the argument, or its ``LABEL=``), ``name`` (:func:`name_label`) or ``config``
    (``params.config.name``); an argument with ``LABEL=`` is labelled so whatever ``label_by`` says. Runs of one
    name whose configs differ beyond the seed are told apart by those keys (:func:`distinguish`)."""
    if label_by not in LABEL_BY:
        raise CompareError(f"--label-by: expected one of {', '.join(LABEL_BY)}, got '{label_by}'")
    if not arguments:
        raise CompareError("no run folders given: rlchain compare RUN_FOLDER_OR_GLOB [...]")
    seen: set[str] = set()
    out: list[tuple[str, str, bool]] = []  # (label, folder, whether the label was derived, not chosen)
    for argument in arguments:
        label, pattern = split_label(argument)
        folders = expand(pattern)
        if not folders:
            raise CompareError(f"'{pattern}' matches no folder")
        for folder in folders:
            key = os.path.realpath(folder)
            if key in seen:
                continue
            seen.add(key)
            if label is not None:
                run_label = label
            elif label_by == "glob":
                run_label = pattern
            elif label_by == "config":
                run_label = config_name(folder) or name_label(folder)
            else:
                run_label = name_label(folder)
            out.append((run_label, folder, label is None and label_by != "glob"))
    return distinguish(out)


SEED_KEYS = ("params.seed", "params.config.env_config.seed", "params.config.train_dir",
             "params.config.full_experiment_name")
"""What differs between the seeds of one config: left out when telling same-named runs apart."""


def run_settings(path: str) -> dict[str, str]:
    """The run's ``config.yaml`` as flat ``{'params.config.learning_rate': '0.001', ...}``, without the seed
    keys (:data:`SEED_KEYS`); empty when there is none."""
    raw = read_config(os.path.join(path, "config.yaml"))
    flat: dict[str, str] = {}

    def walk(prefix: str, value: object) -> None:
        if isinstance(value, dict):
            for key, item in value.items():
                walk(f"{prefix}.{key}" if prefix else str(key), item)
        elif prefix not in SEED_KEYS:
            flat[prefix] = repr(value) if isinstance(value, str) else str(value)

    walk("", raw if isinstance(raw, dict) else {})
    return flat


def distinguish(labelled: Sequence[tuple[str, str, bool]]) -> list[tuple[str, str]]:
    """``(label, folder)``; runs that share a label they did not choose (the same config name) but whose configs
    differ in more than the seed get the differing keys added: ``cartpole (learning_rate=0.003)``."""
    by_label: dict[str, list[str]] = {}
    for label, folder, auto in labelled:
        if auto:
            by_label.setdefault(label, []).append(folder)
    extra: dict[str, str] = {}
    for folders in by_label.values():
        if len(folders) < 2:
            continue
        settings = {folder: run_settings(folder) for folder in folders}
        keys = sorted({k for s in settings.values() for k in s
                       if len({str(t.get(k)) for t in settings.values()}) > 1})
        for folder in folders if keys else ():
            shown = ", ".join(f"{k.removeprefix('params.config.').removeprefix('params.')}="
                              f"{settings[folder].get(k, '-').strip(chr(39))}" for k in keys[:3])
            extra[folder] = f" ({shown}{', ...' if len(keys) > 3 else ''})"
    return [(label + extra.get(folder, ""), folder) for label, folder, _ in labelled]


def resolve_tags(requested: Sequence[str], runs: Sequence[Run]) -> list[str]:
    """The tags to compare: ``requested`` (short names ``reward`` / ``success`` allowed), else the reward,
    the success rate when every run has one, and the ``env_info/*`` tags every run has. CompareError for a
    tag some run lacks, naming the run and the tags it has."""
    if requested:
        tags = [TAG_ALIASES.get(tag, tag) for tag in requested]
        for tag in tags:
            for run in runs:
                if tag not in run.curves:
                    have = ", ".join(sorted(run.curves)) or "none"
                    raise CompareError(f"{run.path}: no scalar '{tag}' (it has: {have})")
        return list(dict.fromkeys(tags))
    common = set.intersection(*(set(run.curves) for run in runs)) if runs else set()
    if REWARD not in common:
        missing = next(run for run in runs if REWARD not in run.curves)
        raise CompareError(f"{missing.path}: no '{REWARD}' scalar (no episode finished while it ran?); "
                           f"name the tags to compare with --tag")
    return [REWARD] + ([SUCCESS] if SUCCESS in common else []) + sorted(t for t in common if t.startswith("env_info/"))


def load_runs(arguments: Sequence[str], label_by: str = "name") -> list[Run]:
    """The runs the arguments name, grouped by ``label_by``, with all their curves."""
    return [Run(folder, label, config_name(folder), read_curves(folder)) for label, folder in
            group_runs(arguments, label_by)]


def groups(runs: Sequence[Run]) -> dict[str, list[Run]]:
    """Runs by label, in the order the labels first appear."""
    out: dict[str, list[Run]] = {}
    for run in runs:
        out.setdefault(run.label, []).append(run)
    return out


__all__ = ["REWARD", "SUCCESS", "LABEL_BY", "CompareError", "Curve", "Run", "curve_from_events", "read_curves",
           "config_name", "name_label", "run_settings", "distinguish", "expand", "split_label", "group_runs",
           "resolve_tags", "load_runs", "groups"]
