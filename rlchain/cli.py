"""Command line with rl_games' flags: ``runner.py --train|--play --file cfg.yaml [key.path=value ...]``."""

from __future__ import annotations

import argparse
import signal
import sys
import warnings
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.packaged import resolve_config
from rlchain.errors import DistributedError, DivergenceError, EnvError, NetworkError
from rlchain.inference.export.rl_games_checkpoint import export_rl_games
from rlchain.inference.watch import watch_and_evaluate
from rlchain.log import set_dialect
from rlchain.runner import Runner, locate_checkpoint
from rlchain.runs.checkpoint import CheckpointError, trusting
from rlchain.runs.wandb_logger import TrackingError
from rlchain.tuning.search import run_search

MODE_HELP = {  # rlchain COMMAND --help: the usage line and the options that command reads
    "train": ("%(prog)s NAME|PATH [options] [key.path=value ...]",
              {"checkpoint", "num_actors", "seed", "sigma", "track", "wandb_project_name", "wandb_entity",
               "trust_checkpoint", "distributed", "overrides"}),
    "play": ("%(prog)s [NAME|PATH] --checkpoint CKPT [options] [key.path=value ...]",
             {"checkpoint", "num_actors", "seed", "sigma", "games", "stochastic", "video", "untrained",
              "trust_checkpoint", "overrides"}),
    "export": ("%(prog)s [NAME|PATH] --checkpoint CKPT [-o OUT] [--policy NAME]",
               {"checkpoint", "output", "policy", "trust_checkpoint", "overrides"}),
    "tune": ("%(prog)s SEARCH [-o OUT]", {"output"}),
}


def build_parser(prog: str = "runner.py", command: str | None = None) -> argparse.ArgumentParser:
    """rl_games' flags and rlchain's additions; ``prog`` names the command in usage lines. ``command`` (train,
    play, export, tune: ``rlchain COMMAND``) shows only that command's options in ``--help``; all still parse."""
    usage, shown = MODE_HELP[command] if command else (None, None)
    p = argparse.ArgumentParser(prog=prog, usage=usage, description=None if command else
                                "Train or play an rl_games-style config.")
    mode = p.add_mutually_exclusive_group(required=True)
    hide = argparse.SUPPRESS if command else None
    mode.add_argument("-t", "--train", action="store_true", help=hide or "train (resume with --checkpoint)")
    mode.add_argument("-p", "--play", action="store_true", help=hide or "play a checkpoint")
    mode.add_argument("--export", choices=["onnx", "rl_games"], help=hide or "export a checkpoint's deterministic "
                      "policy (onnx) or the checkpoint as rl_games 1.6.5 / 2.0 restore it (rl_games)")
    mode.add_argument("--tune", metavar="SEARCH",
                      help=hide or "Optuna search from a search YAML (pip install rlchain[tune])")
    if command:
        p.add_argument = _shown_only(p.add_argument, shown)  # the config is the usage line's NAME|PATH
    p.add_argument("-f", "--file", help="YAML or JSON config, or a packaged config's name (ppo_cartpole); "
                   "optional for --play: the checkpoint has one")
    p.add_argument("-c", "--checkpoint", help="checkpoint to resume from (--train) or play (--play); "
                   "a shipped one by name (cartpole)")
    p.add_argument("-na", "--num_actors", type=int, help="override the number of envs")
    p.add_argument("--seed", type=int, help="override params.seed")
    p.add_argument("--sigma", type=float, help="fixed sigma (std) for a continuous fixed_sigma policy")
    p.add_argument("--games", type=int, help="--play: episodes to play (player.games_num)")
    p.add_argument("--stochastic", action="store_true", help="--play: sample actions instead of the mode")
    p.add_argument("--untrained", action="store_true", help="--play without --checkpoint: play the untrained "
                   "(freshly initialized) policy on purpose")
    p.add_argument("-o", "--output", help="--export: output file (default: the checkpoint with .onnx, or "
                   "_rl_games.pth); --tune: best config (default: <base name>_best.yaml in the search's run folder)")
    p.add_argument("--policy", help="--export with config.multi_agent: export only this policy (default: all)")
    p.add_argument("--video", metavar="DIR", help="--play: record the games to mp4 in DIR (pip install rlchain[video])")
    p.add_argument("--distributed", action="store_true", help="EmbodiChain's flag: params.config.multi_gpu=true "
                   "(launch with torchrun)")
    p.add_argument("--trust-checkpoint", action="store_true",
                   help="load checkpoints with full pickle, which runs any code stored in them: only for a file "
                        "you trust (by default a checkpoint loads as data and any other object is refused)")
    p.add_argument("--track", action="store_true", help="mirror logs and config to Weights & Biases")
    p.add_argument("--wandb-project-name", default="rlchain")
    p.add_argument("--wandb-entity", default=None)
    p.add_argument("overrides", nargs="*", help="key.path=value, e.g. params.config.learning_rate=1e-3")
    return p


def _shown_only(add_argument: Any, shown: set[str]) -> Any:
    """``add_argument`` that hides (argparse.SUPPRESS) the help of options whose dest is not in ``shown``."""

    def add(*flags: str, **kwargs: Any) -> Any:
        dest = kwargs.get("dest") or next((f.lstrip("-") for f in flags if f.startswith("--")), flags[0])
        if dest.replace("-", "_") not in shown:
            kwargs["help"] = argparse.SUPPRESS
        return add_argument(*flags, **kwargs)

    return add


EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT), as shells report it
EXIT_TERMINATED = 143  # SIGTERM (128 + SIGTERM)


def main(argv: list[str] | None = None, prog: str = "runner.py", command: str | None = None) -> int:
    """Entry point; expected errors print one line and exit with status 2. ``command``: the ``rlchain``
    subcommand this call serves (its --help and hints), None for runner.py's flags."""
    args = build_parser(prog, command).parse_intermixed_args(argv)
    args.prog = prog
    # SIGTERM, the warning format and the hints' dialect are the process's: changed for this call only, so an
    # in-process caller (a test, a notebook, a sweep) gets its own back.
    _terminated.clear()
    previous_sigterm = signal.signal(signal.SIGTERM, _terminate)
    previous_format = warnings.formatwarning
    warnings.formatwarning = _one_line_warning
    previous_dialect = set_dialect("rlchain" if prog.startswith("rlchain") else "runner.py")
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*Box .*precision lowered.*")
            status = _report(args)
        return EXIT_TERMINATED if status == EXIT_INTERRUPTED and _terminated else status
    finally:
        signal.signal(signal.SIGTERM, previous_sigterm)
        warnings.formatwarning = previous_format
        set_dialect(previous_dialect)


def _report(args: argparse.Namespace) -> int:
    """Run the command; an expected error is one line on stderr and an exit status."""
    try:
        with trusting(args.trust_checkpoint):
            return _run(args)
    except (ConfigError, CheckpointError) as exc:
        kind = "config error" if isinstance(exc, ConfigError) else "checkpoint error"
        print(f"{kind}: {exc}", file=sys.stderr)
        return 2
    except (ImportError, TrackingError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except (EnvError, DivergenceError, DistributedError, NetworkError) as exc:
        kind = ("env error" if isinstance(exc, EnvError) else "divergence" if isinstance(exc, DivergenceError)
                else "network error" if isinstance(exc, NetworkError) else "distributed error")
        print(f"{kind}: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


_terminated: list[bool] = []  # non-empty once SIGTERM arrived during this call (exit 143, not 130)


def _terminate(signum, frame) -> None:
    """SIGTERM unwinds like Ctrl-C, so logs are flushed and envs closed on the way out."""
    _terminated.append(True)
    raise KeyboardInterrupt


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    """Warnings as one line each, without the source line Python prints by default."""
    return f"warning: {message}\n"


def _play_usage(prog: str) -> str:
    if prog.startswith("rlchain play"):
        return "rlchain play NAME|PATH --checkpoint CKPT (shipped checkpoints: rlchain list)"
    if prog.startswith("rlchain"):
        return f"{prog} --play --file CONFIG --checkpoint CKPT"
    return "python runner.py --play --file CONFIG --checkpoint CKPT"


def _needs_config(args: argparse.Namespace) -> str:
    """What to type instead, in the words the user launched with."""
    if args.play:
        return f"a checkpoint is required: {_play_usage(args.prog)}"
    if args.export:
        return f"a checkpoint is required: {args.prog} [NAME|PATH] --checkpoint CKPT" if \
            args.prog.startswith("rlchain export") else "--export needs --checkpoint CKPT (and --file CONFIG)"
    if args.prog.startswith("rlchain train"):
        return "a config is required: rlchain train NAME|PATH (rlchain list names the packaged ones)"
    return f"--file: a config file is required: {args.prog} --train --file CONFIG"


def _run(args: argparse.Namespace) -> int:

    if args.tune:
        run_search(resolve_config(args.tune), args.output)
        return 0
    if args.export == "rl_games":  # the checkpoint alone: no config needed
        if not args.checkpoint:
            raise ConfigError("", "--checkpoint", "--export needs the checkpoint to export")
        print(f"wrote {export_rl_games(locate_checkpoint(args.checkpoint)[0], args.output)}")
        return 0
    # the Runner resolves --checkpoint (a path or a shipped checkpoint's name) wherever it takes one
    overrides = list(args.overrides)
    if args.distributed:
        overrides.append("params.config.multi_gpu=true")
    if args.num_actors is not None:
        if args.play:
            overrides += ["params.config.player.use_vecenv=true",
                          f"params.config.player.num_actors={args.num_actors}"]
        else:
            overrides.append(f"params.config.num_actors={args.num_actors}")
    if args.games is not None:
        overrides.append(f"params.config.player.games_num={args.games}")
    runner = Runner()
    if args.file:
        runner.load(args.file, overrides)
    elif (args.play or args.export) and args.checkpoint:
        runner.load_from_checkpoint(args.checkpoint, overrides)
    else:
        raise ConfigError("", "", _needs_config(args))
    if args.play and not args.checkpoint and not runner.params.config.player.evaluation:
        if not args.untrained:
            raise ConfigError("", "--checkpoint", f"nothing to play without a checkpoint: {_play_usage(args.prog)}; "
                                                  f"--untrained plays the untrained policy on purpose")
    if args.export:
        if not args.checkpoint:
            raise ConfigError("", "--checkpoint", "--export needs the checkpoint to export")
        runner.export(args.checkpoint, args.output, args.policy)
        return 0
    if args.train:
        result = runner.train(checkpoint=args.checkpoint, seed=args.seed, sigma=args.sigma, track=args.track,
                              wandb_project=args.wandb_project_name, wandb_entity=args.wandb_entity)
        if result.stop_reason.startswith("interrupted"):
            return EXIT_TERMINATED if "SIGTERM" in result.stop_reason else EXIT_INTERRUPTED
    elif args.video:
        files = runner.record(args.checkpoint, args.video, games=args.games or 1, deterministic=not args.stochastic)
        print("\n".join(files))
    elif runner.params.config.player.evaluation:  # rl_games: watch dir_to_monitor, evaluate new checkpoints
        with trusting(runner.params.config.trust_checkpoint):
            watch_and_evaluate(runner.params, deterministic=False if args.stochastic else None)
    else:
        runner.play(args.checkpoint, deterministic=False if args.stochastic else None, sigma=args.sigma)
    return 0
