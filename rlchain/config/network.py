"""``params.network``: the blocks of the built-in ``actor_critic`` and ``resnet_actor_critic`` builders."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from rlchain.config.fields import non_negative, option, positive

ACTIVATIONS = ("relu", "tanh", "sigmoid", "elu", "selu", "swish", "silu", "gelu", "softplus",
               "leaky_relu", "mish", "identity", "None")
INITIALIZERS = ("default", "const_initializer", "orthogonal_initializer", "glorot_normal_initializer",
                "glorot_uniform_initializer", "variance_scaling_initializer",
                "random_uniform_initializer", "kaiming_normal", "kaiming_uniform", "xavier_uniform",
                "xavier_normal", "None")


@dataclass(frozen=True)
class InitializerConfig:
    """A weight initializer as rl_games names it: ``{name: const_initializer, val: 0}``."""

    name: str = option("default", "initializer name", choices=INITIALIZERS)
    val: float = option(0.0, "constant for const_initializer")
    gain: float = option(1.0, "gain for orthogonal and glorot initializers")
    scale: float = option(1.0, "scale for variance_scaling_initializer")
    mode: str = option("fan_in", "fan mode for variance_scaling / kaiming", choices=("fan_in", "fan_out", "fan_avg"))
    distribution: str = option("truncated_normal", "variance_scaling distribution",
                               choices=("truncated_normal", "normal", "uniform", "untruncated_normal"))
    a: float = option(-0.1, "lower bound for random_uniform_initializer")
    b: float = option(0.1, "upper bound for random_uniform_initializer")
    nonlinearity: str = option("relu", "kaiming nonlinearity")


@dataclass(frozen=True)
class MlpConfig:
    """The fully connected trunk."""

    units: list[int] = option([256, 128, 64], "hidden layer sizes",
                              check=lambda u: None if all(x > 0 for x in u) else "every unit count must be > 0")
    activation: str = option("elu", "hidden activation", choices=ACTIVATIONS)
    initializer: InitializerConfig = option(InitializerConfig(), "hidden layer weight initializer")
    d2rl: bool = option(False, "D2RL: concatenate the input to every hidden layer")
    norm_only_first_layer: bool = option(False, "with normalization: only after the first layer")
    normalization: str | None = option(None, "layer_norm or batch_norm after hidden layers",
                                       choices=("layer_norm", "batch_norm"))
    norm_after_activation: bool = option(False, "with normalization: linear, activation, norm (rl_games 2.0's "
                                                "order, needed to read its checkpoints) instead of linear, norm, "
                                                "activation")
    dropout: float = option(0.0, "rlchain: dropout probability after each hidden activation (EmbodiChain's "
                                 "dropout_p; active in training passes only); 0 = off",
                            check=lambda p: None if 0.0 <= p < 1.0 else "expected 0 <= dropout < 1")


@dataclass(frozen=True)
class ConvSpec:
    """One convolution of ``cnn.convs``."""

    filters: int = option(doc="output channels", check=positive)
    kernel_size: int = option(doc="kernel size (square for conv2d)", check=positive)
    strides: int = option(1, "stride", check=positive)
    padding: int = option(0, "zero padding on each side", check=non_negative)


@dataclass(frozen=True)
class CnnConfig:
    """``network.cnn``: a convolutional encoder in front of the MLP (images or 1-d signals)."""

    type: str = option("conv2d", "conv2d over (C, H, W) or conv1d over (C, L) observations",
                       choices=("conv2d", "conv1d"))
    permute_input: bool = option(True, "observations are channels-last (H, W, C): permute to (C, H, W)")
    activation: str = option("relu", "activation after every convolution", choices=ACTIVATIONS)
    initializer: InitializerConfig = option(InitializerConfig(), "convolution weight initializer")
    convs: list[ConvSpec] = option([], "the convolutions, in order: {filters, kernel_size, strides, padding}",
                                   check=lambda c: None if c else "needs at least one convolution")


@dataclass(frozen=True)
class RnnConfig:
    """``network.rnn``: a recurrent layer; training uses sequences of ``config.seq_length``."""

    name: str = option("lstm", "lstm or gru", choices=("lstm", "gru"))
    units: int = option(128, "hidden units", check=positive)
    layers: int = option(1, "stacked recurrent layers", check=positive)
    before_mlp: bool = option(False, "recurrent layer before the MLP (after it when False)")
    layer_norm: bool = option(False, "LayerNorm on the recurrent output")
    concat_input: bool = option(False, "feed the network input to the recurrent layer alongside the trunk output")
    concat_output: bool = option(False, "append the network input (cnn output, or the flat obs) to the recurrent "
                                        "output")


@dataclass(frozen=True)
class HistoryConfig:
    """``network.history``: a causal transformer over the last ``length`` steps' encoded observations, in the
    recurrent layer's place (after the MLP); training uses sequences of ``config.seq_length``, the window of
    past steps is carried like an RNN's state (rlchain/networks/history.py)."""

    length: int = option(16, "steps in the window, the current one included",
                         check=lambda n: None if n >= 2 else "expected a window of at least 2 steps")
    layers: int = option(1, "transformer blocks", check=positive)
    heads: int = option(2, "attention heads (dim must divide by it)", check=positive)
    dim: int = option(64, "token width: each step's features are projected to it", check=positive)


@dataclass(frozen=True)
class DiscreteSpaceConfig:
    """``space.discrete``: a categorical head over ``Discrete(n)``."""


@dataclass(frozen=True)
class MultiDiscreteSpaceConfig:
    """``space.multi_discrete``: one categorical per action dimension (MultiDiscrete, Tuple of Discrete,
    MultiBinary); the head outputs sum(nvec) logits. Use with model ``multi_discrete_a2c``."""


def _check_bounds(value: object) -> str | None:
    """``logstd_bounds``: None or two numbers, low < high."""
    if value is None:
        return None
    if not isinstance(value, (list, tuple)) or len(value) != 2 or \
            not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value) or value[0] >= value[1]:
        return f"expected [low, high] with low < high, got {value!r}"
    return None


@dataclass(frozen=True)
class ContinuousSpaceConfig:
    """``space.continuous``: a diagonal Gaussian head."""

    mu_activation: str = option("None", "activation on the mean", choices=ACTIVATIONS)
    sigma_activation: str = option("None", "activation on sigma (log-std for the logstd model)",
                                   choices=ACTIVATIONS)
    mu_init: InitializerConfig = option(InitializerConfig(), "mean head initializer")
    sigma_init: InitializerConfig = option(InitializerConfig(name="const_initializer", val=0.0),
                                           "sigma initializer ({name: const_initializer, val: 0})")
    fixed_sigma: bool = option(True, "sigma is a learned vector that does not depend on the input")
    sigma_parametrization: str = option("exp", "rl_games 2.0: how the sigma head's raw output becomes the std "
                                               "(model continuous_a2c_logstd). exp: raw is the log-std (clamped to "
                                               "logstd_bounds, plus min_sigma); softplus: softplus(raw) + "
                                               "min_sigma; linear (alias scalar): the std itself above a smooth "
                                               "floor, floor + softplus(raw - floor), floor = max(min_sigma, 1e-3)",
                                        choices=("exp", "softplus", "linear", "scalar"))
    min_sigma: float = option(0.0, "rl_games 2.0: a floor added to the std (see sigma_parametrization)",
                              check=non_negative)
    logstd_bounds: list[float] | None = option(None, "rl_games 2.0: [low, high] clamp on the raw log-std "
                                                     "(sigma_parametrization exp)", check=_check_bounds)


@dataclass(frozen=True)
class SpaceConfig:
    """Which action head: exactly one of discrete / multi_discrete / continuous."""

    discrete: DiscreteSpaceConfig | None = option(None, "categorical head", empty_is_present=True)
    multi_discrete: MultiDiscreteSpaceConfig | None = option(
        None, "one categorical per action dimension: MultiDiscrete, Tuple of Discrete, MultiBinary "
              "(model multi_discrete_a2c)", empty_is_present=True)
    continuous: ContinuousSpaceConfig | None = option(None, "diagonal Gaussian head", empty_is_present=True)


@dataclass(frozen=True)
class NetworkConfig:
    """``params.network`` for the built-in ``actor_critic`` builder."""

    name: str = option("actor_critic", "registered network builder")
    separate: bool = option(False, "separate critic network with the same architecture")
    space: SpaceConfig = option(SpaceConfig(), "action head")
    mlp: MlpConfig = option(MlpConfig(), "fully connected layers")
    critic_mlp: MlpConfig | None = option(None, "rlchain, with separate: True: the critic's own fully connected "
                                                "layers (units, activation, normalization, dropout, initializer; "
                                                "its value head takes its initializer); default: mlp's")
    cnn: CnnConfig | None = option(None, "convolutional encoder before the MLP")
    rnn: RnnConfig | None = option(None, "recurrent layer (lstm/gru)")
    head: MlpConfig | None = option(None, "rlchain: hidden layers of each output stream after the trunk (and its "
                                          "rnn): the actor's outputs and the value each get their own, with their "
                                          "own activation (RLlib's head_fcnet_hiddens); None: the outputs sit on "
                                          "the trunk")
    history: HistoryConfig | None = option(None, "rlchain: a causal transformer over the last steps in place of "
                                                 "the rnn: {length, layers, heads, dim}")
    normalization: str | None = option(None, "rl_games spelling at network level: layer_norm or batch_norm "
                                             "after MLP hidden layers", choices=("layer_norm", "batch_norm"))
    central_value: bool = option(False, "this network is a value-only critic (only inside "
                                        "config.central_value_config.network)")
    value_activation: str = option("None", "activation on the value output", choices=ACTIVATIONS)
    value_shape: int = option(1, "value outputs (overridden by the env's value_size)", check=positive)


@dataclass(frozen=True)
class ResnetCnnConfig:
    """``network.cnn`` of ``resnet_actor_critic``: IMPALA stages (conv 3x3, max-pool 3x3 / 2, two
    residual blocks) over (C, H, W) images."""

    permute_input: bool = option(True, "observations are channels-last (H, W, C): permute to (C, H, W)")
    conv_depths: list[int] = option([16, 32, 32], "output channels of each IMPALA stage",
                                    check=lambda d: None if d and all(x > 0 for x in d)
                                    else "needs at least one depth, each > 0")
    activation: str = option("relu", "activation inside the residual blocks (rl_games ignores the key and uses "
                                     "relu there); the flattened features get mlp.activation, as in rl_games",
                             choices=ACTIVATIONS)
    initializer: InitializerConfig = option(InitializerConfig(), "convolution weight initializer; default: "
                                                                 "kaiming_normal (fan_out, relu) as rl_games")


@dataclass(frozen=True)
class ResnetNetworkConfig:
    """``params.network`` for the ``resnet_actor_critic`` builder (rl_games' IMPALA network): the
    ``cnn`` stages, then ``mlp`` and ``rnn`` as in ``actor_critic``, and the heads.

    ``require_rewards`` / ``require_last_actions`` feed the previous (clipped) reward and the
    one-hot previous action to the recurrent layer, beside the image features (to the MLP when there
    is no ``rnn``). The env supplies them: ``env_config.use_dict_obs_space: True`` (envpool) or
    ``wrap_impala: True`` (atari_gym), see rlchain/envs/wrappers/reward_action_obs.py.
    """

    # words for its heading in docs/config.md
    doc_note: ClassVar[str] = "rl_games' IMPALA network; mlp, rnn, space as actor_critic"

    name: str = option("resnet_actor_critic", "registered network builder")
    separate: bool = option(False, "separate critic network with the same architecture")
    space: SpaceConfig = option(SpaceConfig(), "action head")
    cnn: ResnetCnnConfig = option(ResnetCnnConfig(), "IMPALA residual encoder")
    mlp: MlpConfig = option(MlpConfig(), "fully connected layers after the encoder")
    rnn: RnnConfig | None = option(None, "recurrent layer (lstm/gru)")
    normalization: str | None = option(None, "layer_norm or batch_norm after MLP hidden layers",
                                       choices=("layer_norm", "batch_norm"))
    value_activation: str = option("None", "activation on the value output", choices=ACTIVATIONS)
    value_shape: int = option(1, "value outputs (overridden by the env's value_size)", check=positive)
    require_rewards: bool = option(False, "the previous reward (clipped to [-1, 1]) as an input of the "
                                          "recurrent layer; needs env_config.use_dict_obs_space (envpool) "
                                          "or wrap_impala (atari_gym)")
    require_last_actions: bool = option(False, "the previous action (one-hot) as an input of the recurrent "
                                               "layer; same env keys as require_rewards")

