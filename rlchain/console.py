"""The ``rlchain`` command (console script, and ``python -m rlchain``): subcommands over runner.py's flags.

    rlchain train ppo_cartpole [key.path=value ...]      # a packaged config by name, or a path
    rlchain play ppo_cartpole --checkpoint cartpole      # a shipped checkpoint by name
    rlchain export onnx --checkpoint cartpole -o cartpole.onnx
    rlchain tune tune/tune_cartpole
    rlchain compare runs/a* runs/b*                      # rlchain.compare.cli, imported on use
    rlchain benchmark a.json b.yaml --seeds 0 1 2        # EmbodiChain's protocol (rlchain.compare.benchmark)
    rlchain list                                         # the packaged configs and checkpoints
    rlchain --train --file cfg.yaml                      # rl_games' flags, exactly as runner.py takes them
"""

from __future__ import annotations

import importlib
import os
import sys

from rlchain.config.packaged import CHECKPOINTS_DIR, CONFIGS_DIR, checkpoint_names, config_names

USAGE = """usage: rlchain COMMAND [ARGS]
       rlchain --train|--play|--export onnx|--tune ... (runner.py's flags)

commands:
  train NAME|PATH [flags] [key.path=value ...]   train a config (a packaged name such as ppo_cartpole, or a file)
  play [NAME|PATH] --checkpoint CKPT [flags]     play a checkpoint (a shipped one by name: cartpole)
  export onnx [NAME|PATH] --checkpoint CKPT      export the deterministic policy to ONNX (pip install rlchain[onnx])
  tune SEARCH [-o OUT]                           Optuna / Ray Tune search (pip install rlchain[tune])
  compare ARGS...                                compare run folders (rlchain compare --help)
  benchmark CFG... [--seeds ...]                 EmbodiChain's benchmark protocol over configs x seeds
  list                                           the packaged configs and checkpoints

Each command's options: rlchain COMMAND --help (rlchain train --help)."""

MODES = {"train": ["--train"], "play": ["--play"], "tune": ["--tune"]}


def _with_config(mode: list[str], rest: list[str]) -> list[str]:
    """runner.py's argv for ``rlchain <mode> [NAME|PATH] rest...``: a leading bare word is the config."""
    if rest and not rest[0].startswith("-") and "=" not in rest[0]:
        if mode == ["--tune"]:
            return mode + rest
        return mode + ["--file", rest[0]] + rest[1:]
    return mode + rest


def list_packaged() -> str:
    """Each packaged config once (its shortest name, other names in brackets) and the shipped checkpoints."""
    by_path: dict[str, list[str]] = {}
    for name, path in config_names().items():
        by_path.setdefault(path, []).append(name)
    rows = []
    for path, names in by_path.items():
        names.sort(key=lambda n: (len(n), n))
        rel = os.path.relpath(path, CONFIGS_DIR).replace(os.sep, "/")
        rows.append((names[0], rel, [n for n in names[1:] if n != os.path.splitext(rel)[0]]))
    width = max(len(row[0]) for row in rows)
    lines = [f"configs (rlchain train NAME), in {CONFIGS_DIR}:"]
    lines += [f"  {name:<{width}}  {rel}" + (f"  (also: {', '.join(more)})" if more else "")
              for name, rel, more in sorted(rows)]
    lines.append(f"checkpoints (--checkpoint NAME), in {CHECKPOINTS_DIR}:")
    lines += [f"  {name:<{width}}  {os.path.basename(path)}" for name, path in checkpoint_names().items()]
    return "\n".join(lines)


def compare(argv: list[str]) -> int:
    """``rlchain compare``: rlchain.compare.cli's main, imported here so other commands do not load it."""
    try:
        module = importlib.import_module("rlchain.compare.cli")
    except ModuleNotFoundError as exc:
        if exc.name not in ("rlchain.compare", "rlchain.compare.cli"):
            print(f"error: rlchain compare needs {exc.name}: {exc}", file=sys.stderr)
            return 2
        print("error: rlchain compare is not part of this rlchain install (no module rlchain.compare.cli)",
              file=sys.stderr)
        return 2
    return int(module.main(argv) or 0)


def _cli():
    """rlchain.cli (runner.py's flags): imported only by the commands that train, play, export or tune, so
    ``--help``, ``list`` and ``compare`` start without torch."""
    return importlib.import_module("rlchain.cli")


def main(argv: list[str] | None = None) -> int:
    """Dispatch a subcommand; anything that starts with a flag goes to runner.py's parser as it is."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(USAGE)
        return 0 if argv else 2
    command, rest = argv[0], argv[1:]
    if command.startswith("-"):
        return _cli().main(argv, prog="rlchain")
    if command in MODES and ("-h" in rest or "--help" in rest):  # that command's options, whatever else is given
        return _cli().main(["--help"], prog=f"rlchain {command}", command=command)
    if command in MODES:
        return _cli().main(_with_config(MODES[command], rest), prog=f"rlchain {command}", command=command)
    if command == "export":
        if not rest or rest[0] != "onnx":
            print("error: rlchain export: the format comes first: rlchain export onnx --checkpoint CKPT",
                  file=sys.stderr)
            return 2
        argv = ["--help"] if "-h" in rest or "--help" in rest else _with_config(["--export", "onnx"], rest[1:])
        return _cli().main(argv, prog="rlchain export onnx", command="export")
    if command == "compare":
        return compare(rest)
    if command == "benchmark":  # imported on use, like compare
        return int(importlib.import_module("rlchain.compare.benchmark").main(rest) or 0)
    if command == "list":
        print(list_packaged())
        return 0
    known = [*MODES, "export", "compare", "benchmark", "list"]
    print(f"error: unknown command '{command}' (one of {', '.join(known)}; rlchain --help)", file=sys.stderr)
    return 2
