"""rl_games checkpoints in and out: pure conversions between rl_games' ``.pth`` dict and rlchain's.

rlchain's networks carry rl_games' tensor names and parameter order (networks/actor_critic.py, sac_network.py), so
a file crosses with a prefix map at most. rl_games (1.6.5 and 2.0) saves PPO as ``{'model', 'epoch', 'frame',
'optimizer', 'last_mean_rewards', 'env_state'}``, ``model`` being rlchain's model state dict as it is
(``a2c_network.*``, ``running_mean_std.*``, ``value_mean_std.*``; every key prefixed ``_orig_mod.`` when the model
was compiled), a central value as ``assymetric_vf_nets`` (its model's state dict under ``model.``) and
``assymetric_vf_optimizer``. SAC is ``{'actor', 'critic', 'critic_target', 'running_mean_std', 'epoch', 'frame',
'actor_optimizer', 'critic_optimizer', 'log_alpha_optimizer'}``, 2.0 adds ``log_alpha`` and ``last_mean_rewards``
(1.6.5 keeps no temperature: a resume starts from ``init_alpha``, as rl_games 1.6.5 does): rlchain's SAC model
holds them as ``network.actor.*``, ``network.critic.*``, ``critic_target.*``, ``running_mean_std.*``, ``log_alpha``.
Each optimizer holds its network's parameters in the same order in both, so its state carries over by position.

Only tensors, numbers and dicts are read or written: the functions work on what a ``weights_only`` load returns.
A network rlchain does not build (another layout, D2RL, ...) fails to load with the first key that does not fit;
the other way, rlchain's norm before the activation (rl_games cannot compute it) is a ValueError.
"""

from __future__ import annotations

import re
from typing import Any

COMPILED_PREFIX = "_orig_mod."
ORIGIN = "rl_games"
"""``state['origin']`` of a converted checkpoint (it holds no RNG streams, episodes or env state)."""
SAC_PARTS = {"actor": "network.actor.", "critic": "network.critic.", "critic_target": "critic_target.",
             "running_mean_std": "running_mean_std."}
"""rl_games' SAC checkpoint part -> the prefix of its tensors in rlchain's SAC model."""
SAC_OPTIMIZERS = {"actor_optimizer": "actor_opt", "critic_optimizer": "critic_opt", "log_alpha_optimizer": "alpha_opt"}
PPO_PREFIXES = ("a2c_network.", "running_mean_std.", "value_mean_std.")
_NORM_BEFORE_ACTIVATION = re.compile(r"(?:^|\.)(?:actor_mlp|critic_mlp|mlp)\.(\d+)\.weight$")


def strip_compiled(names: dict[str, Any]) -> dict[str, Any]:
    """``names`` without torch.compile's ``_orig_mod.`` anywhere in a key."""
    return {key.replace(COMPILED_PREFIX, ""): value for key, value in names.items()}


def is_sac(state: Any) -> bool:
    """Whether ``state`` is an rl_games SAC checkpoint (1.6.5 or 2.0)."""
    return isinstance(state, dict) and all(isinstance(state.get(k), dict) for k in ("actor", "critic", "critic_target"))


def is_rl_games_checkpoint(state: Any) -> bool:
    """Whether ``state`` (a loaded ``.pth``) is an rl_games PPO or SAC checkpoint."""
    if not isinstance(state, dict) or "format" in state:
        return False
    model = state.get("model")
    if isinstance(model, dict):
        return any(key.replace(COMPILED_PREFIX, "").startswith(("a2c_network.", "running_mean_std.")) for key in model)
    return is_sac(state)


def best_reward(state: dict[str, Any]) -> float:
    """rlchain's ``best_reward`` as rl_games' ``last_mean_rewards`` (its own start value when none is finite)."""
    best = state.get("best_reward")
    return float(best) if best is not None and best == best and abs(best) != float("inf") else -1000000000.0


def from_rl_games(state: dict[str, Any]) -> dict[str, Any]:
    """An rl_games PPO or SAC checkpoint as rlchain's checkpoint dict: ``model``, ``epoch``, ``frames``,
    ``best_reward``, ``central_value`` when it has one, and rl_games' optimizer states for
    :func:`resume_agent_states`. ``origin`` says where it came from."""
    best = state.get("last_mean_rewards", None)
    converted: dict[str, Any] = {"origin": ORIGIN, "epoch": int(state.get("epoch", 0)),
                                 "frames": int(state.get("frame", 0)),
                                 "best_reward": float(best) if best is not None else float("-inf")}
    if "model" not in state:  # SAC: its parts under the SAC model's prefixes
        model = {SAC_PARTS[part] + key: value for part in SAC_PARTS
                 for key, value in strip_compiled(state.get(part) or {}).items()}
        if state.get("log_alpha") is not None:
            model["log_alpha"] = state["log_alpha"].detach().reshape(()).float()
        else:
            converted["keep_built"] = ["log_alpha"]
        converted["rl_games_optimizers"] = {ours: state[theirs] for theirs, ours in SAC_OPTIMIZERS.items()
                                            if isinstance(state.get(theirs), dict)}
        unread = ["replay_buffer"]
    else:
        model = strip_compiled(dict(state["model"]))
        if isinstance(state.get("optimizer"), dict):
            converted["rl_games_optimizers"] = {"optimizer": state["optimizer"]}
        if isinstance(state.get("assymetric_vf_nets"), dict):
            nets = strip_compiled(state["assymetric_vf_nets"])
            outside = [k for k in nets if not k.startswith("model.")]
            if outside:
                raise ValueError(f"'assymetric_vf_nets.{outside[0]}' is outside rl_games' central value model")
            converted["central_value"] = {k[len("model."):]: v for k, v in nets.items()}
            if isinstance(state.get("assymetric_vf_optimizer"), dict):
                converted["rl_games_cv_optimizer"] = state["assymetric_vf_optimizer"]
        unread = ["scaler", "pbt_params"]
    converted["model"] = model
    unread = [key for key in unread if state.get(key) is not None]
    if unread:
        converted["rl_games_unread"] = unread
    return converted


def optimizer_state(saved: dict[str, Any], template: dict[str, Any]) -> dict[str, Any]:
    """rl_games' optimizer state ``saved`` as the state dict of rlchain's optimizer ``template`` (its own
    ``state_dict()``, the same parameters in the same order): per-parameter state by position, the learning rate
    rl_games had; rlchain's other group settings kept."""
    ids = [i for group in template["param_groups"] for i in group["params"]]
    theirs = [i for group in saved.get("param_groups", []) for i in group["params"]]
    if len(ids) != len(theirs):
        raise ValueError(f"the rl_games optimizer holds {len(theirs)} parameters, rlchain's {len(ids)}")
    per_param = saved.get("state", {})
    groups = [dict(group) for group in template["param_groups"]]
    lr = saved["param_groups"][0].get("lr") if saved.get("param_groups") else None
    for group in groups:
        if lr is not None:
            group["lr"] = float(lr)
    return {"state": {mine: per_param[their] for mine, their in zip(ids, theirs) if their in per_param},
            "param_groups": groups}


def resume_agent_states(converted: dict[str, Any], agent: dict[str, Any], names: list[str] | None = None,
                        cv_agent: dict[str, Any] | None = None, cv_names: list[str] | None = None
                        ) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """rl_games' optimizer states on this run's agents, for a resume from a converted checkpoint: PPO's one
    optimizer (or SAC's three) on ``agent`` (a state dict), the central value's (``assymetric_vf_nets``) on
    ``cv_agent`` (only when the file has a central value and the run one); each ``lr`` the one rl_games had.
    Returns (agent, central value agent or None); a layout that does not fit raises ValueError saying which part.
    ``names`` / ``cv_names`` (the trainable parameters' names) are not needed: the order is rl_games' own."""
    agent = dict(agent)
    for ours, saved in converted.get("rl_games_optimizers", {}).items():
        if isinstance(agent.get(ours), dict):
            agent[ours] = optimizer_state(saved, agent[ours])
    if "optimizer" in converted.get("rl_games_optimizers", {}) and "optimizer" in agent:
        agent["lr"] = float(agent["optimizer"]["param_groups"][0]["lr"])
    if "central_value" not in converted or cv_agent is None:
        return agent, None
    if "rl_games_cv_optimizer" in converted:
        cv_agent = dict(cv_agent)
        try:
            cv_agent["optimizer"] = optimizer_state(converted["rl_games_cv_optimizer"], cv_agent["optimizer"])
        except ValueError as exc:
            raise ValueError(f"central value: {exc}") from None
        cv_agent["lr"] = float(cv_agent["optimizer"]["param_groups"][0]["lr"])
    return agent, cv_agent


def _check_rl_games_computes(model: dict[str, Any]) -> None:
    """A ValueError naming the first tensor rl_games' actor-critic cannot hold: one outside its model, or a norm
    layer right after a linear layer (rlchain's default order; rl_games normalizes after the activation); or a
    critic MLP unlike the actor's (rl_games' separate network builds both from the one mlp block)."""
    actor = {k.replace(".actor_mlp.", ".critic_mlp.", 1): v.shape for k, v in model.items() if ".actor_mlp." in k}
    critic = {k: v.shape for k, v in model.items() if ".critic_mlp." in k}
    if critic and critic != actor:
        raise ValueError("the critic's layers differ from the actor's (network.critic_mlp); rl_games' separate "
                         "actor_critic gives both the one mlp block")
    for key, value in model.items():
        if not key.startswith(PPO_PREFIXES):
            raise ValueError(f"'{key}' is outside the network and its normalizers: rl_games' model has no place "
                             f"for it")
        match = _NORM_BEFORE_ACTIVATION.search(key)
        if match is not None and value.dim() == 1:
            linear = model.get(f"{key[:match.start(1)]}{int(match.group(1)) - 1}.weight")
            if linear is not None and linear.dim() == 2:
                raise ValueError(f"'{key}' is a normalization layer before the activation (rlchain's default "
                                 f"order): rl_games normalizes after it, so rl_games cannot compute this network "
                                 f"(train with network.mlp.norm_after_activation: True)")


def to_rl_games(state: dict[str, Any]) -> dict[str, Any]:
    """An rlchain PPO or SAC checkpoint dict as the dict rl_games 1.6.5 / 2.0 restore: PPO ``model``, ``optimizer``,
    the central value's ``assymetric_vf_nets`` / ``assymetric_vf_optimizer``; SAC its parts, ``log_alpha`` and
    three optimizers; ``epoch``, ``frame``, ``last_mean_rewards``, ``env_state``."""
    model, agent = dict(state["model"]), state.get("agent") or {}
    out: dict[str, Any] = {}
    if any(k.startswith(SAC_PARTS["actor"]) for k in model):  # SAC (the builder's target copy is not the trained one)
        parts = {part: {k[len(prefix):]: v for k, v in model.items() if k.startswith(prefix)}
                 for part, prefix in SAC_PARTS.items()}
        other = [k for k in model if k != "log_alpha" and not k.startswith((*SAC_PARTS.values(), "network.critic_"))]
        if other:
            raise ValueError(f"'{other[0]}' has no place in rl_games' SAC checkpoint")
        out.update({part: tensors for part, tensors in parts.items() if tensors or part != "running_mean_std"})
        if "log_alpha" in model:
            out["log_alpha"] = model["log_alpha"].detach().clone()
        out.update({theirs: agent[ours] for theirs, ours in SAC_OPTIMIZERS.items()
                    if isinstance(agent.get(ours), dict)})
    else:
        _check_rl_games_computes(model)
        out["model"] = model
        if isinstance(agent.get("optimizer"), dict):
            out["optimizer"] = agent["optimizer"]
        if isinstance(state.get("central_value"), dict):
            _check_rl_games_computes(state["central_value"])
            out["assymetric_vf_nets"] = {f"model.{k}": v for k, v in state["central_value"].items()}
            cv_optimizer = (state.get("central_value_agent") or {}).get("optimizer")
            if isinstance(cv_optimizer, dict):
                out["assymetric_vf_optimizer"] = cv_optimizer
    out.update(epoch=int(state.get("epoch", 0)), frame=int(state.get("frames", 0)),
               last_mean_rewards=best_reward(state), env_state=None)
    return out


__all__ = ["ORIGIN", "from_rl_games", "is_rl_games_checkpoint", "optimizer_state", "resume_agent_states",
           "strip_compiled", "to_rl_games"]
