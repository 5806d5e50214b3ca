"""Generate docs/config.md from the schema: ``python -m rlchain.config.docs > docs/config.md``."""

from __future__ import annotations

import dataclasses
import math
import re
import types
import typing

from rlchain.config import compat
from rlchain.config.algo_keys import config_class_of
from rlchain.config.multi_agent import PolicySpec
from rlchain.config.multi_input import InputConfig
from rlchain.config.network import InitializerConfig
from rlchain.registry import ALGOS, NETWORKS, network_config_class

# The top-level blocks come from the registries (:func:`roots`): each registered algorithm's ``params.config``
# class and each registered network builder's block class, plus EXTRA_ROOTS (blocks parsed from a dict).
# Every field whose type is a dataclass (or Optional of one, or a list of one) becomes a section of its own,
# recursively (see ``sections``), so no nested block can be left out. The qualifier tells apart blocks of
# different types that share a key path (``params.network.cnn`` of actor_critic and of resnet_actor_critic).
EXTRA_ROOTS = [
    ("params.config.multi_agent.policies.<name> (one policy of config.multi_agent; docs/multi_agent.md)",
     "params.config.multi_agent.policies.<name>", PolicySpec, "multi_agent"),
    ("params.network.inputs.<key> (builder multi_input: the encoder of one observation key; "
     "docs/robot_learning.md)", "params.network.inputs.<key>", InputConfig, "multi_input"),
]


def _note(cls: type) -> str:
    """The class's own ``doc_note`` (not a base class's): words for its heading."""
    return cls.__dict__.get("doc_note", "")


def roots() -> list[tuple[str, str, type, str]]:
    """(heading, key path, dataclass, qualifier) of every top-level block: the ``params.config`` class of
    each registered algorithm (algorithms sharing a class share a section), the ``params.network`` class
    of each registered builder that declares one, then EXTRA_ROOTS."""
    algos: dict[type, list[str]] = {}
    for name in ALGOS.names():
        algos.setdefault(config_class_of(name), []).append(name)
    networks: dict[type, list[str]] = {}
    for name in NETWORKS.names():
        cls = network_config_class(name)
        if cls is not None:
            networks.setdefault(cls, []).append(name)
    out = []
    for cls, names in algos.items():
        qualifier = "algo " + " / ".join(names)
        note = _note(cls)
        out.append((f"params.config for {qualifier}" + (f" ({note})" if note else ""), "params.config", cls,
                    qualifier))
    for cls, names in networks.items():
        qualifier = "builder " + " / ".join(names)
        note = _note(cls)
        out.append((f"params.network ({qualifier}" + (f": {note}" if note else "") + ")", "params.network", cls,
                    qualifier))
    return out + EXTRA_ROOTS


# Extra words for a nested section's heading, by key path.
NOTES = {
    "params.config.self_play_config": "an env with set_opponent, see rlchain/training/self_play.py",
    "params.config.env_runners": "Ray env workers: `env_runners: {}` or `vecenv_type: RAY` for the defaults; "
                                 "algos appo / impala: their runners, threads or Ray actors (docs/appo.md)",
    "params.config.central_value_config": "asymmetric actor-critic; the env sets use_central_value",
    "params.network.space": "exactly one; an empty value like `discrete:` selects it",
    "params.network.rnn": "training uses sequences of config.seq_length",
    "params.config.obs_groups": "teacher, student and critic views of one observation; docs/distillation.md",
}

# A block type met at several key paths gets one section that names them all.
BLOCK_NAMES = {InitializerConfig: "initializer blocks"}

# Extra words for one key's row, by full key path: blocks that are plain dicts handed on as they are.
ROW_NOTES = {
    "params.config.central_value_config.network": (
        "; parsed like params.network: a built-in builder's block has the keys of its params.network "
        "sections, a registered builder without config_class gets the dict as it is"),
}


HEADER = """# Configuration reference

Generated from the config classes of `rlchain/config/` (`network.py`, `run.py`, `actor_critic.py`, `ppo.py`,
`appo.py`, `off_policy.py`) by `python -m rlchain.config.docs > docs/config.md`; a unit test fails when this
file and the classes disagree.

A config file is YAML (or JSON) with one top-level `params` block:

| key | meaning |
|---|---|
| `params.seed` | seed for python, numpy, torch and the envs (`--seed` overrides) |
| `params.algo.name` | `a2c_discrete` or `a2c_continuous` (PPO), `sac`, `dqn`, `appo` or `impala` (asynchronous, V-trace), or a registered algo |
| `params.model.name` | `discrete_a2c`, `multi_discrete_a2c` (MultiDiscrete / Tuple of Discrete / MultiBinary actions), `continuous_a2c_logstd` (sigma is log-std), `continuous_a2c` (sigma is std), `soft_actor_critic`, `dqn`; rl_games' old `*_lstm` names are read as these (see Renamed keys) |
| `params.network` | network block; `name: actor_critic` and `resnet_actor_critic` are built in, user builders via `register_network` |
| `params.config` | training keys below |
| `params.torch_threads` | `torch.set_num_threads` for the training process (default on CPU: half the cores, at most 4, for envs with threads of their own such as envpool; rlchain's tensor envs take the update's count; on CUDA: torch's choice). On a CPU a maximum: each rollout takes only the cores other processes left idle during the last rollout (measured from /proc/stat less this run's own CPU time), so two threads never fight another program for two cores |
| `params.update_threads` | CPU threads for the gradient updates only, while the envs are idle (rlchain key). Default: every core of the process's share, at most 4, never fewer than the rollout's, when `torch_threads` is unset too (with `torch_threads` set, the same count), less the cores other processes kept busy during the last update (the first update: a 0.2 s sample of /proc/stat at start). 2 on an idle 2-core machine: PPO train steps/s 1.10-1.17x on envpool HalfCheetah, Ant and Hopper, SAC 1.26x; a shared core stalls every op of a multi-threaded update, many times slower. An explicit value is kept as it is, whatever the load |
| `params.malloc` | `keep` (default) or `default`, rlchain key: on Linux with glibc, `keep` sets glibc's malloc to reuse freed memory (mmap threshold 32 MiB, no trimming) so the tensors an epoch allocates again and again do not come back as fresh pages (a page fault and zeroing per 4 KB): 1.16-1.34x PPO train steps/s on tensor envs at 4,096 envs, envpool level, on a 2-core Xeon. Freed memory stays with the process until it ends; `default` leaves glibc as it is. No effect elsewhere |
| `params.load_checkpoint`, `params.load_path` | deprecated, no effect: pass `--checkpoint` |
| `params.import_modules` | list of Python modules imported before building (register your own networks/envs there) |
| `params.config.algo_observer` | rl_games 2.0: `default` or `isaac` adds rl_games' DefaultAlgoObserver / IsaacAlgoObserver (`rlchain.rl_games.common.algo_observer`) to `callbacks`; with `rlchain.rl_games`' Runner an observer passed to `Runner(observer)` wins, as in rl_games |

Status: **yes** = implemented with rl_games' meaning; **deprecated** = accepted with a one-line
warning, no effect; **planned** = an error unless left at its default (the issue that brings it is named).
Each algorithm reads its own `params.config` section below. A key of another algorithm's section (`tau`,
PPO's GAE lambda, with `algo: appo`) is ignored with a one-line warning naming it; any other key not
listed here is an error with a did-you-mean suggestion.

`max_epochs` and `max_frames` count the whole run: a run resumed from a checkpoint at epoch 40 with
`max_epochs: 100` trains 60 more epochs.

Parsing returns a frozen value: the user modules of `params.import_modules` are imported first (by the
Runner), derived keys are filled in once (`minibatch_size` from `minibatch_size_per_env`,
`num_warmup_frames` from `num_warmup_steps`, ...), and nothing assigns to it afterwards. What differs
per process (the seed; under torchrun the rank's device, `env_config.seed` and progress printing) is
its run context, and values changed while training (`set_params`) belong to the run. A checkpoint
stores this resolved config and the run context; `--play` / `--export` without `--file` read it back.
A checkpoint without it (a pre-release rlchain's, holding the input file) is refused in one line.
"""


def _default(f: dataclasses.Field) -> str:
    if f.default is not dataclasses.MISSING:
        value = f.default
    elif f.default_factory is not dataclasses.MISSING:
        value = f.default_factory()
    else:
        return "required"
    if dataclasses.is_dataclass(value):  # name the keys where it differs from its own section's defaults
        plain = type(value)()
        changed = [f"{k.name}={getattr(value, k.name)!r}" for k in dataclasses.fields(value)
                   if getattr(value, k.name) != getattr(plain, k.name)]
        return "(block" + (": " + ", ".join(changed) if changed else "") + ")"
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return "None" if value is None else repr(value) if isinstance(value, str) else str(value)


def _status(f: dataclasses.Field) -> str:
    return f.metadata.get("status", "yes")


@dataclasses.dataclass
class Section:
    """One table of the reference: a block type and every key path it is met at."""

    cls: type
    paths: list[str]
    qualifiers: list[str]  # the roots it is reached from
    heading: str = ""  # set for the roots; built from the paths for nested blocks
    list_item: bool = False  # the paths hold a list of these blocks


def _block_type(tp: typing.Any) -> tuple[type | None, bool]:
    """The dataclass a field holds (itself, Optional of it, or a list of it) and whether it is a list."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        non_none = [a for a in args if a is not type(None)]
        return _block_type(non_none[0]) if len(non_none) == 1 else (None, False)
    if origin is list and len(args) == 1:
        inner, _ = _block_type(args[0])
        return inner, inner is not None
    return (tp, False) if dataclasses.is_dataclass(tp) else (None, False)


def sections() -> list[Section]:
    """Every block reachable from the roots, in depth-first order; one section per block type."""
    out: list[Section] = []
    by_cls: dict[type, Section] = {}
    seen: set[tuple[type, str, str]] = set()

    def visit(cls: type, path: str, qualifier: str) -> None:
        if (cls, path, qualifier) in seen:
            return
        seen.add((cls, path, qualifier))
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            child, is_list = _block_type(hints[f.name])
            if child is None:
                continue
            child_path = f"{path}.{f.name}"
            section = by_cls.get(child)
            if section is None:
                section = by_cls[child] = Section(child, [], [], list_item=is_list)
                out.append(section)
            if child_path not in section.paths:
                section.paths.append(child_path)
            if qualifier not in section.qualifiers:
                section.qualifiers.append(qualifier)
            visit(child, child_path, qualifier)

    for heading, path, cls, qualifier in roots():
        by_cls[cls] = Section(cls, [path], [qualifier], heading)
        out.append(by_cls[cls])
        visit(cls, path, qualifier)
    types_at: dict[str, set[type]] = {}
    for section in out:
        for path in section.paths:
            types_at.setdefault(path, set()).add(section.cls)
    for section in out:
        if section.heading:
            continue
        heading = ", ".join(section.paths)
        if section.cls in BLOCK_NAMES:
            heading = f"{BLOCK_NAMES[section.cls]}: {heading}"
        extras = []
        if any(len(types_at[p]) > 1 for p in section.paths):  # another block type shares the key path
            extras.append(" / ".join(section.qualifiers))
        if section.list_item:
            extras.append("each item of the list")
        extras += [NOTES[p] for p in section.paths if p in NOTES]
        section.heading = heading + (f" ({'; '.join(extras)})" if extras else "")
    return out


def render() -> str:
    """The whole markdown document."""
    lines = [HEADER]
    for section in sections():
        cls = section.cls
        lines += [f"## {section.heading}", ""]
        if not dataclasses.fields(cls):
            name = section.paths[0].rsplit(".", 1)[-1]
            lines += [f"No keys; an empty value (`{name}:`) selects it.", ""]
            continue
        lines += ["| key | type | default | status | meaning |", "|---|---|---|---|---|"]
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            tp = str(hints[f.name]).replace("typing.", "").replace("<class '", "").replace("'>", "")
            tp = re.sub(r"rlchain\.config\.(schema|multi_agent|multi_input|network|run|actor_critic|ppo)\.", "", tp)
            tp = tp.replace(" | ", " or ")
            doc = f.metadata.get("doc", "")
            choices = f.metadata.get("choices")
            if choices:
                doc += " (choices: " + ", ".join("None" if c is None else str(c) for c in choices) + ")"
            for path in section.paths:
                doc += ROW_NOTES.get(f"{path}.{f.name}", "")
            lines.append(f"| `{f.name}` | {tp} | `{_default(f)}` | {_status(f)} | {doc.replace('|', '/')} |")
        lines.append("")
    lines += ["## rl_games keys accepted without effect", "", "| key | note |", "|---|---|"]
    for key, why in {**compat.NO_EFFECT_CONFIG_KEYS,
                     **{f"central_value_config.{k}": v for k, v in compat.NO_EFFECT_CENTRAL_VALUE_KEYS.items()},
                     **{f"network ... {k}": v for k, v in compat.NO_EFFECT_NETWORK_KEYS.items()}}.items():
        lines.append(f"| `{key}` | {why} |")
    lines += ["", "## Renamed keys", "", "| old | new |", "|---|---|"]
    lines += [f"| `{old}` | `{new}` |" for old, new in compat.ALIASES.items()]
    lines += [f"| `params.model.name: {old}` | `{new}` (needs a `network.rnn` block) |"
              for old, new in compat.MODEL_ALIASES.items()]
    lines += ["| `params.network.lstm: {units: N, concated: False}` | `rnn: {name: lstm, units: N}` |"]
    lines += ["", "## rl_games features not implemented (an error when set)", "", "| key | feature |", "|---|---|"]
    lines += [f"| `{k}` | {v} |" for k, v in compat.UNSUPPORTED_CONFIG_KEYS.items()]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":  # python -m imports the rlchain package first: the built-ins are registered
    print(render(), end="")
