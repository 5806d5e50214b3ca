"""Generate docs/config.md from the schema: ``python -m rlchain.config.docs > docs/config.md``."""

from __future__ import annotations

import dataclasses
import math
import typing

from rlchain.config import compat
from rlchain.config.off_policy import DQNConfig, DQNNetworkConfig, SACConfig, SACNetworkConfig
from rlchain.config.schema import (
    ContinuousSpaceConfig,
    DivergenceConfig,
    EnvRunnersConfig,
    EvaluationConfig,
    InitializerConfig,
    MlpConfig,
    NetworkConfig,
    PlayerConfig,
    ResnetCnnConfig,
    ResnetNetworkConfig,
    RewardShaperConfig,
    SelfPlayConfig,
    SpaceConfig,
    TrainConfig,
)

SECTIONS = [
    ("params.config", TrainConfig),
    ("params.config.reward_shaper", RewardShaperConfig),
    ("params.config.player", PlayerConfig),
    ("params.config.divergence", DivergenceConfig),
    ("params.config.evaluation", EvaluationConfig),
    ("params.config.self_play_config (an env with set_opponent, see rlchain/training/self_play.py)",
     SelfPlayConfig),
    ("params.config.env_runners (Ray env workers: `env_runners: {}` or `vecenv_type: RAY` for the defaults)",
     EnvRunnersConfig),
    ("params.network (builder actor_critic)", NetworkConfig),
    ("params.network.mlp", MlpConfig),
    ("params.network.space (exactly one; an empty value like `discrete:` selects it)", SpaceConfig),
    ("params.network.space.continuous", ContinuousSpaceConfig),
    ("params.network (builder resnet_actor_critic: rl_games' IMPALA network; mlp, rnn, space as actor_critic)",
     ResnetNetworkConfig),
    ("params.network.cnn (builder resnet_actor_critic)", ResnetCnnConfig),
    ("initializer blocks (mlp.initializer, mu_init, sigma_init)", InitializerConfig),
    ("params.config for algo sac (keys shared with PPO have the same meaning)", SACConfig),
    ("params.network (builder soft_actor_critic)", SACNetworkConfig),
    ("params.config for algo dqn", DQNConfig),
    ("params.network (builder dqn)", DQNNetworkConfig),
]

HEADER = """# Configuration reference

Generated from `rlchain/config/schema.py` by `python -m rlchain.config.docs > docs/config.md`;
a unit test fails when this file and the schema disagree.

A config file is YAML (or JSON) with one top-level `params` block:

| key | meaning |
|---|---|
| `params.seed` | seed for python, numpy, torch and the envs (`--seed` overrides) |
| `params.algo.name` | `a2c_discrete` or `a2c_continuous` (PPO), `sac`, `dqn`, or a registered algo |
| `params.model.name` | `discrete_a2c`, `multi_discrete_a2c` (MultiDiscrete / Tuple of Discrete / MultiBinary actions), `continuous_a2c_logstd` (sigma is log-std), `continuous_a2c` (sigma is std), `soft_actor_critic`, `dqn`; rl_games' old `*_lstm` names are read as these (see Renamed keys) |
| `params.network` | network block; `name: actor_critic` and `resnet_actor_critic` are built in, user builders via `register_network` |
| `params.config` | training keys below |
| `params.torch_threads` | `torch.set_num_threads` for the training process (default on CPU: half the cores, at most 4; on CUDA: torch's choice) |
| `params.update_threads` | CPU threads for the gradient updates only, while the envs are idle (rlchain key; default: the same as `torch_threads`). Measured on 2 cores: 2 speed up a CNN update (envpool Pong 1.33x) but slow an MLP run beside envpool 4x (OpenMP and envpool threads spin against each other) |
| `params.load_checkpoint`, `params.load_path` | deprecated, no effect: pass `--checkpoint` |
| `params.import_modules` | list of Python modules imported before building (register your own networks/envs there) |

Status: **yes** = implemented with rl_games' meaning; **deprecated** = accepted with a one-line
warning, no effect; **planned** = an error unless left at its default (the issue that brings it is named).
Any key not listed here is an error with a did-you-mean suggestion.

`max_epochs` and `max_frames` count the whole run: a run resumed from a checkpoint at epoch 40 with
`max_epochs: 100` trains 60 more epochs.
"""


def _default(f: dataclasses.Field) -> str:
    if f.default is not dataclasses.MISSING:
        value = f.default
    elif f.default_factory is not dataclasses.MISSING:
        value = f.default_factory()
    else:
        return "required"
    if dataclasses.is_dataclass(value):
        return "(block)"
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return "None" if value is None else repr(value) if isinstance(value, str) else str(value)


def _status(f: dataclasses.Field) -> str:
    status = f.metadata.get("status", "yes")
    return status


def render() -> str:
    """The whole markdown document."""
    lines = [HEADER]
    for title, cls in SECTIONS:
        lines += [f"## {title}", "", "| key | type | default | status | meaning |", "|---|---|---|---|---|"]
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            tp = str(hints[f.name]).replace("typing.", "").replace("<class '", "").replace("'>", "")
            tp = tp.replace("rlchain.config.schema.", "").replace(" | ", " or ")
            doc = f.metadata.get("doc", "")
            choices = f.metadata.get("choices")
            if choices:
                doc += " (choices: " + ", ".join("None" if c is None else str(c) for c in choices) + ")"
            lines.append(f"| `{f.name}` | {tp} | `{_default(f)}` | {_status(f)} | {doc.replace('|', '/')} |")
        lines.append("")
    lines += ["## rl_games keys accepted without effect", "", "| key | note |", "|---|---|"]
    for key, why in {**compat.NO_EFFECT_CONFIG_KEYS, **{f"network ... {k}": v for k, v in
                                                          compat.NO_EFFECT_NETWORK_KEYS.items()}}.items():
        lines.append(f"| `{key}` | {why} |")
    lines += ["", "## Renamed keys", "", "| old | new |", "|---|---|"]
    lines += [f"| `{old}` | `{new}` |" for old, new in compat.ALIASES.items()]
    lines += [f"| `params.model.name: {old}` | `{new}` (needs a `network.rnn` block) |"
              for old, new in compat.MODEL_ALIASES.items()]
    lines += ["| `params.network.lstm: {units: N, concated: False}` | `rnn: {name: lstm, units: N}` |"]
    lines += ["", "## rl_games features not implemented (an error when set)", "", "| key | feature |", "|---|---|"]
    lines += [f"| `{k}` | {v} |" for k, v in compat.UNSUPPORTED_CONFIG_KEYS.items()]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(render(), end="")
