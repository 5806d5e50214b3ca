"""RLlib's model settings (``DefaultModelConfig`` / the old-stack ``model={...}``) -> rlchain's network block.

RLlib's default encoder, as its ``Catalog`` builds it:

- a flat observation: an MLP of ``fcnet_hiddens`` (``fcnet_activation`` after every layer, the last too), then
  the policy / value heads: ``head_fcnet_hiddens`` (``head_fcnet_activation``) and a linear output;
- an image (a 3-d Box, channels last): the convolutions of ``conv_filters`` (``conv_activation``), flattened,
  then the heads; ``fcnet_hiddens`` is not used;
- ``use_lstm``: that encoder as the tokenizer, then one LSTM of ``lstm_cell_size``, then the heads; sequences of
  ``max_seq_len`` steps in training.

rlchain's ``actor_critic`` network is the same chain: ``cnn`` -> ``mlp`` -> ``rnn`` (after the MLP) -> ``head``
(the policy's and the value's own layers, each with ``head_fcnet_activation``) -> linear outputs; a value
network of its own (``vf_share_layers=False``) is ``separate: True``.
"""

from __future__ import annotations

from typing import Any

from rlchain.config.errors import ConfigError

ACTIVATIONS = {"tanh": "tanh", "relu": "relu", "elu": "elu", "swish": "swish", "silu": "swish", "gelu": "gelu",
               "sigmoid": "sigmoid", "linear": "None", None: "None", "softplus": "softplus", "selu": "selu"}
"""RLlib's activation names -> rl_games' (``linear`` / None: no activation)."""


def _bad(config: Any, key: str, message: str) -> ConfigError:
    return ConfigError(type(config).__name__, key, message)


def activation(config: Any, key: str) -> str:
    """The rl_games activation of model key ``key`` (a one-line error naming the choices)."""
    value = config.model_config.get(key)
    if value not in ACTIVATIONS:
        raise _bad(config, f"model_config.{key}", f"{value!r}; choices: {', '.join(str(a) for a in ACTIVATIONS if a)}")
    return ACTIVATIONS[value]


def layer_sizes(config: Any, key: str) -> list[int]:
    """Model key ``key`` as a list of layer sizes (a one-line error otherwise)."""
    value = config.model_config.get(key) or []
    if not isinstance(value, (list, tuple)) or not all(isinstance(u, int) and not isinstance(u, bool) and u > 0
                                                       for u in value):
        raise _bad(config, f"model_config.{key}", f"expected a list of layer sizes, got {value!r}")
    return list(value)


def is_image(obs_space: Any) -> bool:
    """RLlib's image observation: a 3-d Box (height, width, channels)."""
    return obs_space is not None and len(getattr(obs_space, "shape", None) or ()) == 3


def conv_specs(config: Any, filters: Any) -> list[dict[str, int]]:
    """RLlib's ``conv_filters`` ``[[out_channels, kernel, stride(, padding)], ...]`` -> rlchain's ``cnn.convs``.

    RLlib pads ``same`` unless a filter says ``valid``; rlchain's padding is a number: ``same`` is
    ``(kernel - 1) // 2`` (the same output size for odd kernels at stride 1; at larger strides within one pixel).
    """
    if not isinstance(filters, (list, tuple)) or not filters:
        raise _bad(config, "model_config.conv_filters", f"expected [[out_channels, kernel, stride], ...], got "
                                                        f"{filters!r}")
    out = []
    for i, spec in enumerate(filters):
        if not isinstance(spec, (list, tuple)) or len(spec) not in (3, 4):
            raise _bad(config, f"model_config.conv_filters[{i}]", f"expected [out_channels, kernel, stride] or "
                                                                  f"[..., padding], got {spec!r}")
        channels, kernel, stride = spec[0], _square(config, i, "kernel", spec[1]), _square(config, i, "stride",
                                                                                           spec[2])
        padding = spec[3] if len(spec) == 4 else "same"
        if padding not in ("same", "valid"):
            raise _bad(config, f"model_config.conv_filters[{i}]", f"padding {padding!r}: expected 'same' or 'valid'")
        out.append({"filters": int(channels), "kernel_size": kernel, "strides": stride,
                    "padding": (kernel - 1) // 2 if padding == "same" else 0})
    return out


def _square(config: Any, index: int, what: str, value: Any) -> int:
    if isinstance(value, (list, tuple)):
        if len(value) != 2 or value[0] != value[1]:
            raise _bad(config, f"model_config.conv_filters[{index}]", f"{what} {list(value)}: rlchain's convolutions "
                                                                      f"are square, give one number")
        value = value[0]
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise _bad(config, f"model_config.conv_filters[{index}]", f"{what} {value!r}: expected a number > 0")
    return int(value)


def actor_critic_network(config: Any, obs_space: Any, continuous: bool, *, separate: bool | None = None
                         ) -> tuple[dict[str, Any], int | None]:
    """(rlchain's ``actor_critic`` network block, the RNN sequence length or None) of ``config``'s model
    settings for ``obs_space``. ``separate``: the value network is its own (default: not ``vf_share_layers``)."""
    model = config.model_config
    heads = layer_sizes(config, "head_fcnet_hiddens")
    image = is_image(obs_space)
    if image and not model.get("conv_filters"):
        raise _bad(config, "model_config.conv_filters", f"image observations {tuple(obs_space.shape)}: give the "
                                                        f"convolutions, e.g. [[16, 4, 2], [32, 4, 2], [256, 11, 1, "
                                                        f"'valid']] (RLlib's own defaults depend on the image size)")
    if obs_space is not None and not image and len(getattr(obs_space, "shape", None) or (1,)) > 1:
        raise _bad(config, "env", f"observations of shape {tuple(obs_space.shape)}: RLlib's default models take a "
                                  f"flat vector or an image (height, width, channels)")
    units = [] if image else layer_sizes(config, "fcnet_hiddens")
    act = "relu" if image and not units else activation(config, "fcnet_activation")
    network: dict[str, Any] = {
        "name": "actor_critic",
        "separate": (not model.get("vf_share_layers", False)) if separate is None else separate,
        "mlp": {"units": units, "activation": act, "initializer": {"name": "default"}},
    }
    if heads:  # RLlib's pi and vf heads: each its own layers after the encoder (and the LSTM)
        network["head"] = {"units": heads, "activation": activation(config, "head_fcnet_activation"),
                           "initializer": {"name": "default"}}
    if model.get("conv_filters"):
        if not image:
            raise _bad(config, "model_config.conv_filters", f"set for observations of shape "
                                                            f"{tuple(getattr(obs_space, 'shape', ()) or ())}: "
                                                            f"convolutions take images (height, width, channels)")
        network["cnn"] = {"type": "conv2d", "permute_input": True, "activation": activation(config, "conv_activation"),
                          "initializer": {"name": "default"}, "convs": conv_specs(config, model["conv_filters"])}
    seq_len = None
    if model.get("use_lstm"):
        cell = model.get("lstm_cell_size")
        seq_len = model.get("max_seq_len")
        for key, value in (("lstm_cell_size", cell), ("max_seq_len", seq_len)):
            if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                raise _bad(config, f"model_config.{key}", f"expected a whole number > 0, got {value!r}")
        network["rnn"] = {"name": "lstm", "units": int(cell), "layers": 1, "before_mlp": False}
    if continuous:
        network["space"] = {"continuous": {"mu_activation": "None", "sigma_activation": "None",
                                           "mu_init": {"name": "default"},
                                           "sigma_init": {"name": "const_initializer", "val": 0},
                                           "fixed_sigma": bool(model.get("free_log_std", False))}}
    else:
        network["space"] = {"discrete": None}
    return network, seq_len

