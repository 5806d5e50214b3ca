"""Train the peer library rl_games from a YAML config, for benchmarking.

Run it with the interpreter of the venv that holds rl_games (see
benchmarks/README.md, "Installing the peer")::

    /work/rlg-venv/bin/python benchmarks/peers/rl_games_driver.py --file CFG.yaml

rl_games writes its TensorBoard events under ``./runs/<name>_<dd-HH-MM-SS>/
summaries`` relative to the current working directory (its ``train_dir``
default), with the ``rewards/step`` tag (x = frames, y = mean episode reward)
that ``benchmarks/peers/compare.py`` reads.  This script only drives rl_games'
public ``Runner`` API; it contains no rl_games code.
"""

import argparse
import signal
import sys

import yaml


def parse_args(argv=None):
    """Parse the command line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--file", required=True, help="rl_games YAML config")
    p.add_argument("--seed", type=int, default=None,
                   help="override params.seed (rl_games uses time() if unset)")
    p.add_argument("--torch-compile", choices=("config", "on", "off"),
                   default="config",
                   help="config: keep the YAML's config.torch_compile "
                        "(rl_games defaults it to True); on/off: force it")
    p.add_argument("--max-epochs", type=int, default=None,
                   help="override config.max_epochs")
    p.add_argument("--torch-threads", type=int, default=None,
                   help="params.torch_threads: rl_games calls torch.set_num_threads with it; unset, rl_games "
                        "uses min(4, cores) (2 on 2 cores) whatever OMP_NUM_THREADS says")
    p.add_argument("--device", default=None,
                   help="override config.device (e.g. cpu)")
    p.add_argument("--tensor-env", action="store_true",
                   help="config.env_name is one of rlchain's tensor envs (TorchCartPole-v0, ...): "
                        "register it through rl_games' vecenv API first "
                        "(rl_games_tensor_env.py)")
    p.add_argument("--num-actors", type=int, default=None,
                   help="override config.num_actors, scaling minibatch_size to keep "
                        "the same number of minibatches per epoch")
    return p.parse_args(argv)


def load_config(args):
    """Load the YAML and apply the command-line overrides."""
    with open(args.file) as f:
        cfg = yaml.safe_load(f)
    params = cfg["params"]
    config = params["config"]
    if args.seed is not None:
        params["seed"] = args.seed
    if args.torch_compile != "config":
        config["torch_compile"] = args.torch_compile == "on"
    if args.max_epochs is not None:
        config["max_epochs"] = args.max_epochs
    if args.torch_threads is not None:
        params["torch_threads"] = args.torch_threads
    if args.num_actors is not None:
        if "minibatch_size" in config:  # (minibatch_size_per_env scales with num_actors by itself)
            batch = int(config["horizon_length"]) * int(config["num_actors"])
            count = max(1, batch // int(config["minibatch_size"]))
            config["minibatch_size"] = int(config["horizon_length"]) * args.num_actors // count
        config["num_actors"] = args.num_actors
    if args.device is not None:
        config["device"] = args.device
        if "device_name" in config:
            config["device_name"] = args.device
        if isinstance(config.get("env_config"), dict) and "device" in config["env_config"]:
            config["env_config"]["device"] = args.device  # a tensor env's batch lives there
    mlp = params.get("network", {}).get("mlp", {})
    if mlp.get("activation") == "silu":
        mlp["activation"] = "swish"  # rl_games' name for the same nn.SiLU (rlchain takes both)
    return cfg


def _exit_on_sigterm(signum, frame):
    """Turn SIGTERM into SystemExit so atexit handlers run.

    tensorboardX registers an atexit hook that flushes the event file
    (it otherwise flushes only every 120 s), and Ray shuts its workers down
    at exit; a bare SIGTERM would skip both.
    """
    sys.exit(128 + signum)


def main(argv=None):
    """Build an rl_games Runner and train."""
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    args = parse_args(argv)
    cfg = load_config(args)
    if args.tensor_env:
        from rl_games_tensor_env import register  # beside this file

        register(cfg["params"]["config"]["env_name"])
    from rl_games.torch_runner import Runner  # imported late: heavy

    runner = Runner()
    runner.load(cfg)
    runner.reset()
    runner.run({"train": True, "play": False, "checkpoint": None,
                "sigma": None})


if __name__ == "__main__":
    main()
