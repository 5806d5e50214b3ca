"""``params.network`` of the ``multi_input`` builder: an encoder per observation key, then the usual trunk.

A Dict observation (a camera image beside proprioception) is kept per key; ``inputs`` says how each key is
encoded (a key it does not name gets ``encoder: auto``). The encoders' features are concatenated and go
through ``mlp`` (and ``rnn``) and the actor-critic heads exactly as in ``actor_critic``; with the
``soft_actor_critic`` or ``dqn`` model they feed SAC's actor and critics or DQN's Q-network instead. SB3's
``MultiInputPolicy`` maps here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from rlchain.config.fields import non_negative, option, positive
from rlchain.config.network import ACTIVATIONS, ConvSpec, NetworkConfig

ENCODERS = ("auto", "cnn", "impala", "mlp", "flatten", "embedding", "none")
"""auto: embedding for a Discrete / MultiDiscrete key, cnn for an image (3 dims), mlp for anything else; none: the
key is not read by this network."""

DEFAULT_CONVS = [ConvSpec(filters=16, kernel_size=3, strides=2, padding=1),
                 ConvSpec(filters=32, kernel_size=3, strides=2, padding=1)]
"""Two stride-2 3x3 convolutions: small camera images (24 to 84 pixels) on a CPU."""


@dataclass(frozen=True)
class InputConfig:
    """One entry of ``network.inputs``: how the observation key of that name is encoded."""

    encoder: str = option("auto", "auto (embedding for a Discrete / MultiDiscrete key, cnn for an image of 3 dims, "
                                  "mlp otherwise), cnn, impala (IMPALA residual stages), mlp, flatten (the values as "
                                  "they are; a Discrete key one-hot), embedding (a learned vector per value of a "
                                  "Discrete / MultiDiscrete key) or none (the key is not read)",
                          choices=ENCODERS)
    permute_input: bool | None = option(None, "cnn / impala: the image is channels-last (H, W, C) and is permuted "
                                              "to (C, H, W); None: channels-last unless its first dim is its "
                                              "smallest (SB3's rule; rlchain's tensor envs give (C, H, W))")
    convs: list[ConvSpec] = option(DEFAULT_CONVS, "cnn: the convolutions {filters, kernel_size, strides, padding}",
                                   check=lambda c: None if c else "needs at least one convolution")
    conv_depths: list[int] = option([16, 32, 32], "impala: output channels of each stage",
                                    check=lambda d: None if d and all(x > 0 for x in d)
                                    else "needs at least one depth, each > 0")
    units: list[int] = option([64], "mlp: layer sizes; cnn / impala: a linear layer (with activation) to units[-1] "
                                    "features after the convolutions ([] for none)",
                              check=lambda u: None if all(x > 0 for x in u) else "every unit count must be > 0")
    activation: str = option("relu", "the encoder's activation", choices=ACTIVATIONS)
    dim: int = option(16, "embedding: the size of the vector each value maps to (a MultiDiscrete key: per "
                          "component, concatenated)", check=positive)
    random_shift: int = option(0, "cnn / impala: DrQ's augmentation, pad the image by this many pixels (edge "
                                  "replicated) and crop it back at a random offset, in training passes only; 0 = off",
                               check=non_negative)


@dataclass(frozen=True)
class MultiInputNetworkConfig(NetworkConfig):
    """``params.network`` for the ``multi_input`` builder: ``inputs`` (an encoder per observation key), then
    ``mlp``, ``rnn``, ``space``, ``separate`` as in ``actor_critic`` (its ``cnn`` block is not used)."""

    doc_note: ClassVar[str] = "an encoder per observation key, then mlp, rnn, space as actor_critic"

    name: str = option("multi_input", "registered network builder")
    inputs: dict[str, Any] = option({}, "observation key -> {encoder, permute_input, convs, conv_depths, units, "
                                        "activation, dim, random_shift}; a key not named gets encoder auto; a key "
                                        "set to encoder none may be absent from the observations")
    dueling: bool | None = option(None, "model dqn only: dueling head, Q = V + A - mean(A) (null: True, as the dqn "
                                        "network)")
