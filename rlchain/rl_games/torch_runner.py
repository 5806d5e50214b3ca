"""rl_games' ``Runner`` on rlchain: ``Runner(observer).load(cfg_dict)``, ``reset()``, ``run(args)``.

    runner = Runner(IsaacAlgoObserver())
    runner.load(agent_cfg)  # {'params': {...}}: rl_games' config as a dict
    runner.reset()
    runner.run({"train": True, "play": False, "sigma": None, "checkpoint": resume_path})

Training is rlchain's (:class:`rlchain.runner.Runner` and its loop); the observer is one of its callbacks,
called at rl_games' points. ``params.env`` (Isaac Lab's clip settings, read by its script) is set aside,
and ``params.load_checkpoint`` / ``params.load_path`` (IsaacGymEnvs) resume when ``run`` gets no
``checkpoint``. :meth:`create_player` builds an rl_games-style player (:mod:`.common.player`).
"""

from __future__ import annotations

import copy
from typing import Any

from rlchain import env_configurations
from rlchain.config.params import Params
from rlchain.envs import vecenv as _vecenv
from rlchain.registry import ENVS
from rlchain.rl_games.algos_torch.players import PLAYERS
from rlchain.rl_games.common.algo_observer import AlgoObserver, DefaultAlgoObserver, IsaacAlgoObserver
from rlchain.rl_games.common.object_factory import ObjectFactory
from rlchain.rl_games.common.player import BasePlayer
from rlchain.runner import Runner as _RlchainRunner
from rlchain.training.callback_context import ObserverAlgo
from rlchain.training.events import Callback

REQUIRED_BLOCKS = ("algo", "model", "network", "config")
"""The ``params`` blocks a run needs; rl_games' ``load_config`` takes a config without some (its tests build
such), and so does this Runner: the config is then checked when first used (``run``, ``create_player``)."""

CONFIG_OBSERVERS = {"default": DefaultAlgoObserver, "isaac": IsaacAlgoObserver}
"""rl_games 2.0's ``config.algo_observer`` names -> the observer the Runner builds (an injected one wins)."""

SCRIPT_KEYS = ("env",)
"""Top-level ``params`` keys a launch script reads and rl_games' runner ignores (Isaac Lab's ``params.env``)."""

OBJECT_KEYS = ("env_info", "vec_env")
"""``params.config`` keys that hold Python objects, not settings: rl_games' agent and player read the env's
spaces from ``env_info`` and step the env given as ``vec_env`` instead of creating one."""


def _builtin(name: str) -> Any:
    """The marker builder of an algorithm rlchain trains itself (a user's builder replaces it)."""

    def build(**kwargs: Any) -> Any:
        raise RuntimeError(f"'{name}' is trained by rlchain's loop; register your own builder to create an agent")

    build.rlchain_builtin = True  # type: ignore[attr-defined]
    return build


def _copy_keeping_objects(config: dict[str, Any]) -> dict[str, Any]:
    """A deep copy of ``{'params': ...}`` whose ``config.env_info`` / ``vec_env`` are the objects given (an env
    is used, not copied)."""
    inner = config["params"].get("config")
    objects = {k: inner[k] for k in OBJECT_KEYS if k in inner} if isinstance(inner, dict) else {}
    if not objects:
        return copy.deepcopy(config)
    stripped = {**config, "params": {**config["params"], "config": {k: v for k, v in inner.items()
                                                                     if k not in objects}}}
    out = copy.deepcopy(stripped)
    out["params"]["config"].update(objects)
    return out


def _register_vecenv_type(config: dict[str, Any]) -> None:
    """rl_games 2.0: a config's ``vecenv_type`` binds its ``env_name`` in ``env_configurations.configurations``
    (when the name is not registered yet), so the env is built by that vector env."""
    vecenv_type, env_name = config.get("vecenv_type"), config.get("env_name")
    if vecenv_type and isinstance(env_name, str) and env_name not in ENVS:
        env_configurations.register(env_name, {"vecenv_type": vecenv_type})


def _vec_env_creator(env: Any) -> Any:
    """A vecenv_type creator that returns ``env`` (rl_games' ``config['vec_env']``)."""
    return lambda config_name, num_actors, **kwargs: env


class TrainInfoCallback(Callback):
    """rl_games' ``vec_env.set_train_info(frames, algo)`` at the start of every epoch, for an rl_games
    IVecEnv that has it (curricula)."""

    def on_train_start(self, ctx: Any) -> None:
        self._tell(ctx)

    def on_epoch_end(self, ctx: Any, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        self._tell(ctx)

    def _tell(self, ctx: Any) -> None:
        tell = getattr(ctx.training_env, "set_train_info", None)  # the adapter hands it on to the IVecEnv
        if callable(tell):
            tell(ctx.state.frames, ObserverAlgo(ctx, in_epoch=True))  # before the epoch's rollout


class StopFnCallback(Callback):
    """rl_games 2.0's ``config['stop_fn']``: ``stop_fn(algo) -> bool`` after every epoch; true stops the run
    (with its last checkpoint, as a signal would)."""

    def __init__(self, stop_fn: Any) -> None:
        self.stop_fn = stop_fn

    def on_epoch_end(self, ctx: Any, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        if self.stop_fn(ObserverAlgo(ctx)):
            ctx.request_stop("stop_fn returned True")


def _checkpoint(args: dict[str, Any], fallback: str | None) -> str | None:
    path = args.get("checkpoint")
    return path if path else fallback


class Runner:
    """rl_games' Runner: holds one config (``load``) and trains or plays with it (``run``)."""

    def __init__(self, algo_observer: Any = None) -> None:
        self._observer_injected = algo_observer is not None
        self.algo_observer = algo_observer if algo_observer is not None else DefaultAlgoObserver()
        self.stop_fn: Any = None
        self.params: dict[str, Any] | None = None
        self.default_config: dict[str, Any] | None = None
        self.algo_name: str | None = None
        self.seed: int | None = None
        self.load_path: str | None = None
        self.script_params: dict[str, Any] = {}
        self.last_result: Any = None
        self._runner: _RlchainRunner | None = None
        self.objects: dict[str, Any] = {}
        # rl_games' factories: a builder registered by a script replaces rlchain's training / player
        self.algo_factory = ObjectFactory()
        for name in ("a2c_continuous", "a2c_discrete", "sac"):
            self.algo_factory.register_builder(name, _builtin(name))
        self.player_factory = ObjectFactory()
        for name, player in PLAYERS.items():
            self.player_factory.register_builder(name, player)

    def reset(self) -> None:
        """Nothing to reset (rl_games' is a no-op too)."""

    def load(self, yaml_config: dict[str, Any]) -> None:
        """Take a config dict (``{'params': {...}}``, a YAML as read) and validate it with rlchain's schema:
        a bad key is a one-line ConfigError naming it."""
        if not isinstance(yaml_config, dict) or not isinstance(yaml_config.get("params"), dict):
            raise ValueError("Runner.load: expected the config as a dict with a 'params' dict (a YAML as read)")
        config = _copy_keeping_objects(yaml_config)
        self.default_config = _copy_keeping_objects(config)["params"]
        self.load_config(config["params"])

    def load_config(self, params: dict[str, Any]) -> None:
        """Validate ``params`` (the ``params`` block) and keep it."""
        params = _copy_keeping_objects({"params": params})["params"]
        self.script_params = {key: params.pop(key) for key in SCRIPT_KEYS if key in params}
        load_checkpoint, load_path = params.pop("load_checkpoint", False), params.pop("load_path", None)
        self.load_path = load_path if load_checkpoint and load_path else None
        config = params.get("config")
        self.objects = {}
        if isinstance(config, dict):
            self.objects = {key: config.pop(key) for key in OBJECT_KEYS if config.get(key) is not None}
            for key in OBJECT_KEYS:
                config.pop(key, None)
            if "vec_env" in self.objects:  # train on the env given (a one-off vecenv_type naming it)
                name = f"rl_games_vec_env_{id(self.objects['vec_env'])}"
                _vecenv.register(name, _vec_env_creator(self.objects["vec_env"]), overwrite=True)
                config["vecenv_type"] = name
            config.update(self.objects)  # where rl_games' agents and players read them; not validated
            self.stop_fn = config.pop("stop_fn", None)  # a callable: a callback here, not a config value
            if self.stop_fn is not None and not callable(self.stop_fn):
                raise ValueError(f"params.config.stop_fn: expected a callable(algo) -> bool, got {self.stop_fn!r}")
            name = config.pop("algo_observer", None)  # rl_games 2.0: the config names the observer ...
            if name and not self._observer_injected:  # ... unless one was given
                if name not in CONFIG_OBSERVERS:
                    raise ValueError(f"params.config.algo_observer: expected one of {', '.join(CONFIG_OBSERVERS)}, "
                                     f"got {name!r}")
                self.algo_observer = CONFIG_OBSERVERS[name]()
            _register_vecenv_type(config)
        self.params = params
        self.algo_name = (params.get("algo") or {}).get("name")
        self._runner = None
        self.seed = params.get("seed")
        if all(key in params for key in REQUIRED_BLOCKS):  # a whole config: checked now, as a YAML is
            self._parsed()

    def _parsed(self) -> Params:
        """The validated config; a partial one (rl_games builds nothing until ``run``) is checked here, at first use."""
        if self.params is None:
            raise RuntimeError("call Runner.load(config) first")
        if self._runner is None:
            params = {k: v for k, v in self.params.items()}
            if isinstance(params.get("config"), dict):
                params["config"] = {k: v for k, v in params["config"].items() if k not in OBJECT_KEYS}
            runner = _RlchainRunner().load({"params": params})
            runner.layout = "rl_games"  # rl_games' checkpoint names, tags and frame axis
            self._runner = runner
            self.seed = runner.params.seed
        return self._runner.params

    def run(self, args: dict[str, Any]) -> Any:
        """``{'train': True}`` trains, ``{'play': True}`` plays (training when neither); ``checkpoint``
        resumes (or is played), ``sigma`` sets a fixed sigma. Returns rlchain's TrainResult / PlayResult."""
        if args.get("train"):
            return self.run_train(args)
        if args.get("play"):
            return self.run_play(args)
        return self.run_train(args)

    def run_train(self, args: dict[str, Any]) -> Any:
        """Train with rlchain's loop, the observer called at rl_games' points; resume from ``checkpoint``."""
        print("Started to train", flush=True)
        builder = self.algo_factory.get(self.algo_name or "")
        if builder is not None and not getattr(builder, "rlchain_builtin", False):
            return self._run_own_agent(args)
        parsed = self._parsed()
        observer = self.algo_observer
        callbacks: list[Any] = [TrainInfoCallback()]
        if observer is not None and type(observer) is not AlgoObserver:
            callbacks.insert(0, observer)
        if self.stop_fn is not None:
            callbacks.append(StopFnCallback(self.stop_fn))
        self.last_result = self._runner.train(checkpoint=_checkpoint(args, self.load_path), seed=parsed.seed,
                                              sigma=args.get("sigma"), callbacks=callbacks)
        return self.last_result

    def _run_own_agent(self, args: dict[str, Any]) -> Any:
        """An agent a script registered with ``algo_factory``: built, restored and trained as rl_games does."""
        agent = self.algo_factory.create(self.algo_name, base_name="run", params=self.params)
        path = _checkpoint(args, self.load_path)
        if path:
            agent.restore(path)
        if args.get("sigma") is not None and callable(getattr(agent, "override_sigma", None)):
            agent.override_sigma(float(args["sigma"]))
        self.last_result = agent.train()
        return self.last_result

    def run_play(self, args: dict[str, Any]) -> Any:
        """Play ``player.games_num`` games with the ``checkpoint``'s policy."""
        print("Started to play", flush=True)
        player = self.create_player()
        path = _checkpoint(args, self.load_path)
        if path:
            player.restore(path)
        if args.get("sigma") is not None:
            player.override_sigma(float(args["sigma"]))
        self.last_result = player.run()
        return self.last_result

    def create_player(self) -> BasePlayer:
        """The player of this config's algorithm (untrained until ``restore``): ``player_factory``'s builder,
        called with ``params=`` as rl_games calls it; an algorithm without one gets :class:`BasePlayer`."""
        builder = self.player_factory.get(self.algo_name or "")
        if builder is None:
            return BasePlayer(self.params, self._parsed())
        if isinstance(builder, type) and issubclass(builder, BasePlayer):
            return builder(self.params, self._parsed())
        return builder(params=self.params)


__all__ = ["Runner"]
