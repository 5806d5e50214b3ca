"""``import ray.rllib...`` resolved to ``rlchain.rllib...`` in this process; ``ray`` and ``ray.tune`` stay Ray's.

:func:`install` puts a finder first on ``sys.meta_path`` (:class:`rlchain.faces.ModuleAlias`): ``ray.rllib`` or
``ray.rllib.X.Y`` is answered with the module object ``rlchain.rllib.X.Y`` (one object under both names). A
``ray.rllib`` module the face does not offer is a one-line :class:`FaceImportError` saying what to use instead,
never RLlib's own module (a mix of the two would not run). Nothing is written to disk; other processes see the
real RLlib.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
from types import ModuleType
from typing import Any

from rlchain.faces import ModuleAlias
from rlchain.rllib import tune_hooks
from rlchain.rllib.examples import example_in_classes, installed_rllib_version
from rlchain.rllib.face_error import FaceImportError

INSTEAD = {
    "ray.rllib.core.learner": "RLlib's Learner subclasses are not run: rlchain's PPO loss options are config keys",
    "ray.rllib.connectors": "connectors are not run (env_to_module's MeanStdFilter and FlattenObservations aside): "
                            "preprocess in a gymnasium wrapper",
    "ray.rllib.connectors.env_to_module.frame_stacking": "RLlib's frame-stacking connectors are not run: wrap the env "
                                                         "in gymnasium's FrameStackObservation inside a "
                                                         "register_env creator",
    "ray.rllib.connectors.learner": "learner connectors are not run (rlchain's update reads the env's observations; "
                                    "for FrameStackingLearner wrap the env in gymnasium's FrameStackObservation "
                                    "inside a register_env creator)",
    "ray.rllib.core.distribution": "RLlib's action distribution classes are not run: a module's action_dist_inputs "
                                   "are read by rlchain's categorical (Discrete) or diagonal Gaussian (Box); a custom "
                                   "distribution (a temperature, autoregressive actions) has no equivalent",
    "ray.rllib.offline": "offline RL is not in rlchain",
    "ray.rllib.policy": "the old Policy API: use algo.get_module() / compute_single_action",
    "ray.rllib.evaluation": "the old RolloutWorker API: rlchain steps the envs itself",
    "ray.rllib.models": "the old ModelV2 API: set the network with rl_module(model_config=...)",
    "ray.rllib.execution": "the old execution API: algo.train() runs one iteration",
    "ray.rllib.env.single_agent_episode": "RLlib's episodes are its connectors' data, and connectors are not run: "
                                          "a callback's episode has get_return(), get_length(), get_rewards(), "
                                          "get_observations(-1), custom_data",
    "ray.rllib.env.multi_agent_episode": "RLlib's episodes are its connectors' data, and connectors are not run: "
                                         "a callback's episode has get_return(), get_length(), get_rewards(), "
                                         "custom_data",
    "ray.rllib.env.single_agent_env_runner": "EnvRunners are not built standalone: the face steps the envs inside "
                                             "algo.train() (its runner: algo.env_runner)",
    "ray.rllib.env.multi_agent_env_runner": "EnvRunners are not built standalone: the face steps the envs inside "
                                            "algo.train() (its runner: algo.env_runner)",
    "ray.rllib.env.wrappers.atari_wrappers": "RLlib's Atari wrappers are not offered: wrap the env in gymnasium's "
                                             "AtariPreprocessing and FrameStackObservation inside a register_env "
                                             "creator",
    "ray.rllib.env.vector": "the face vectorizes the envs itself: a callback's env is a gymnasium VectorEnv "
                            "(multi-agent: None)",
    "ray.rllib.utils.metrics.stats": "RLlib's Stats classes are not offered: the face's MetricsLogger reduces by "
                                     "log_value(key, value, reduce='ema' | 'mean' | 'min' | 'max' | 'sum' | "
                                     "'lifetime_sum' | 'item' | 'item_series', window=..., ema_coeff=...)",
    "ray.rllib.env.utils": "RLlib's env utilities (try_import_pyspiel, OpenSpiel's wrapper) are not offered: wrap a "
                           "game as a MultiAgentEnv (turn-based: only the mover in the obs dict)",
    "ray.rllib.env.external": "RLlib's external-env protocol (an EnvRunner serving a client env over TCP) is not "
                              "offered: wrap the simulator's client in a gymnasium env class whose reset / step "
                              "talk to it, and pass that class (or a register_env creator) to environment()",
    "ray.rllib.core.rl_module.marl_module": "RLlib 2.60 has no marl_module (the script is older): "
                                            "MultiRLModuleSpec(rl_module_specs={policy: RLModuleSpec(...)}) from "
                                            "ray.rllib.core.rl_module.multi_rl_module",
    "ray.rllib.utils.metrics.learner_info": "the old API stack's learner info: read the result's "
                                            "learners/<policy>/... keys (LEARNER_RESULTS in ray.rllib.utils.metrics)",
    "ray.rllib.env.apis": "TaskSettableEnv is not in RLlib 2.60 either: give your env a set_task method and call it "
                          "from on_train_result through algorithm.env_runner_group.foreach_env_runner",
}
"""``ray.rllib`` packages the face does not offer -> what to use instead (docs/rllib.md)."""


OFFERED_ALGORITHMS = ("ppo", "appo", "impala", "dqn", "sac")
"""``ray.rllib.algorithms.<name>`` packages the face has (PPO, APPO, IMPALA, DQN, SAC)."""

OTHER_ALGORITHMS = {
    "bc": "offline RL", "cql": "offline RL", "marwil": "offline RL", "iql": "offline RL",
    "dreamerv3": "model-based RL (DreamerV3)", "tqc": "TQC (SACConfig trains rlchain's SAC, twin critics)",
}
"""RLlib algorithms outside rlchain -> what they are, for the one line."""


def _algorithm_instead(fullname: str) -> str | None:
    """The line for an algorithm package the face does not have (``ray.rllib.algorithms.cql``), or None."""
    parts = fullname.split(".")
    if parts[:3] != ["ray", "rllib", "algorithms"] or len(parts) < 4:
        return None
    if any(part == "learner" or part.endswith("_learner") for part in parts[4:]):  # ppo.torch.ppo_torch_learner
        return INSTEAD["ray.rllib.core.learner"]
    if parts[3] in OFFERED_ALGORITHMS:
        return None
    what = OTHER_ALGORITHMS.get(parts[3], f"RLlib's {parts[3]}")
    return (f"{what} is not in rlchain: the face trains PPO, APPO, IMPALA, DQN and SAC "
            f"(ray.rllib.algorithms.ppo / appo / impala / dqn / sac)")


def _example_instead(fullname: str) -> str | None:
    """The line for an RLlib example module found neither in the face nor in the installed RLlib, or None."""
    if not fullname.startswith("ray.rllib.examples."):
        return None
    version = installed_rllib_version()
    if version is None:
        return "RLlib's example classes are read from an installed RLlib, and none is installed beside rlchain"
    moved = example_in_classes(fullname)
    if moved is not None:
        return f"the installed RLlib ({version}) has it as {moved}: the script is older than that RLlib"
    return (f"not among the example classes of the installed RLlib ({version}) either, which the face imports "
            f"as they are: the script is newer than that RLlib")


def instead(fullname: str) -> str:
    for prefix in sorted(INSTEAD, key=len, reverse=True):  # the most specific entry first
        if fullname == prefix or fullname.startswith(prefix + "."):
            return INSTEAD[prefix]
    return (_algorithm_instead(fullname) or _example_instead(fullname)
            or "see docs/rllib.md for what the face offers")


def missing_name_instead(module: str, name: str) -> str:
    """What to use instead of ``from module import name``, a ``ray.rllib`` module the face has without ``name``."""
    if name.endswith("Policy") and module.startswith("ray.rllib.algorithms."):  # PPOTorchPolicy, DQNTFPolicy
        return INSTEAD["ray.rllib.policy"]
    return instead(f"{module}.{name}")


class RLlibAlias(ModuleAlias):
    """Answers ``ray.rllib.*`` with ``rlchain.rllib.*``; a name the face has no module for is a
    :class:`FaceImportError`; Ray Tune's modules get the face's hooks (:mod:`.tune_hooks`)."""

    ALIAS = "ray.rllib"
    TARGET = "rlchain.rllib"

    def find_spec(self, fullname: str, path: object = None, target: object = None
                  ) -> importlib.machinery.ModuleSpec | None:
        if fullname in tune_hooks.HOOKS:
            return _after_loading(fullname, path, tune_hooks.HOOKS[fullname])
        return super().find_spec(fullname, path, target)

    def missing(self, fullname: str) -> None:
        raise FaceImportError(f"{fullname} is not offered by rlchain's RLlib face: {instead(fullname)}",
                              name=fullname) from None


def _after_loading(fullname: str, path: object, hook: Any) -> importlib.machinery.ModuleSpec | None:
    """Ray Tune's own module ``fullname``, with ``hook(module)`` run once it has loaded (:mod:`.tune_hooks`)."""
    spec = importlib.machinery.PathFinder.find_spec(fullname, path)
    if spec is None or spec.loader is None:
        return spec
    loader = spec.loader

    class _Hooked(importlib.abc.Loader):
        def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType | None:
            return loader.create_module(spec)

        def exec_module(self, module: ModuleType) -> None:
            loader.exec_module(module)
            hook(module)

    spec.loader = _Hooked()
    return spec


install = RLlibAlias.install
uninstall = RLlibAlias.uninstall
