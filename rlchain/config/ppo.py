"""``params.config`` of PPO (algos ``a2c_continuous`` / ``a2c_discrete``): :class:`PPOConfig`, the keys
only PPO reads (GAE, the clipped surrogate, RNN sequences, torch.compile, env groups, the asymmetric critic,
self-play, multi-agent policies) on top of the actor-critic keys it shares with appo and impala."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

from rlchain.config.actor_critic import ActorCriticConfig
from rlchain.config.compile import check_compile, check_cuda_graph
from rlchain.config.errors import ConfigError
from rlchain.config.exploration import RndConfig, SymmetryConfig
from rlchain.config.fields import check_env_groups, non_negative, option, positive, unit_interval
from rlchain.config.multi_agent import MultiAgentConfig
from rlchain.config.network import NetworkConfig
from rlchain.config.network_block import check_registered, has_rnn, network_name, parse_network
from rlchain.config.obs_groups import ObsGroupsConfig
from rlchain.registry import NETWORKS


@dataclass(frozen=True)
class SelfPlayConfig:
    """``config.self_play_config``: train against frozen copies of the policy loaded into the env.

    The env provides ``set_opponent(policy, env_ids)`` (see rlchain/training/self_play.py). After
    every epoch the mean score of the games finished since the last opponent update is checked;
    once ``games_to_check`` games are in and it is above ``update_score``, a frozen copy of the
    current policy becomes the opponent of ``env_update_num`` envs.
    """

    update_score: float = option(doc="replace the opponent once the mean score is above this (e.g. a win "
                                     "rate with check_scores, a mean episode reward without)")
    games_to_check: int = option(doc="games (since the last update) the mean score is taken over",
                                 check=positive)
    check_scores: bool = option(False, "score = the env's per-game scores (pop_scores(): win 1, draw 0.5, "
                                       "loss 0) instead of the episode rewards")
    env_update_num: int = option(1, "envs that get the new opponent per update: a window of envs that moves "
                                    "on by one env per update, as in rl_games", check=positive)
    deterministic: bool = option(False, "the frozen opponent acts with its distribution's mode instead of "
                                        "sampling (rlchain)")


@dataclass(frozen=True)
class CentralValueConfig:
    """``config.central_value_config``: a critic that sees the env's full ``state`` while the actor
    sees ``obs`` (asymmetric actor-critic). It has its own network, optimizer and minibatches; the
    actor's own value head is then not trained. Needs an env with ``use_central_value = True``.
    """

    # parsed in load.py like params.network: a NetworkConfig for actor_critic, the raw dict for a user builder
    network: Any = option(doc="the critic's network block: actor_critic (mlp, cnn, rnn; `central_value: True`; "
                              "no action head) or a registered network, built with `central_value: True` and "
                              "returning (value, states)")
    learning_rate: float = option(5e-4, "critic Adam learning rate", check=positive)
    lr_schedule: str | None = option(None, "None (constant) or linear (to 0 over max_epochs/max_frames)",
                                     choices=("linear", "constant"))
    minibatch_size: int | None = option(None, "critic minibatch size (default: the actor's)", check=positive)
    minibatch_size_per_env: int | None = option(None, "critic minibatch = num_actors * this", check=positive)
    mini_epochs: int = option(4, "critic passes over the batch per epoch", check=positive)
    normalize_input: bool = option(True, "running mean/std normalization of states")
    clip_value: bool = option(False, "clip the value update to e_clip around the old value")
    e_clip: float = option(0.2, "value clip range", check=positive)
    truncate_grads: bool = option(False, "clip gradients to grad_norm")
    grad_norm: float = option(1.0, "max gradient norm", check=positive)
    weight_decay: float = option(0.0, "Adam weight decay", check=non_negative)


@dataclass(frozen=True)
class PPOConfig(ActorCriticConfig):
    """``params.config``: the training keys of an rl_games config (PPO)."""

    # words for its heading in docs/config.md
    doc_note: ClassVar[str] = "PPO"

    env_groups: Any = option("auto", "rlchain, envpool: split the envs into this many groups that step in "
                                     "the background while the policy acts for the other (overlaps env "
                                     "stepping with inference). auto (num_actors even and >= 16) measures at "
                                     "the start: one envpool pool or two, and with two, the pipelined "
                                     "rollout or both stepped together, whichever is faster (the same "
                                     "transitions); else 1. Must divide num_actors", check=check_env_groups)
    tau: float = option(0.95, "GAE lambda", check=unit_interval)
    mini_epochs: int = option(4, "passes over the batch per epoch", check=positive)
    e_clip: float = option(0.2, "PPO clip range", check=positive)
    clip_value: bool = option(False, "clip the value update to e_clip around the old value")
    use_smooth_clamp: bool = option(False, "smooth clamp instead of clamp in the clipped objective")
    kl_loss_coef: float = option(0.0, "KL penalty (RLlib's use_kl_loss / kl_coeff): loss += kl_loss_coef * mean "
                                      "KL(reference policy || current policy), with its gradient; the reference is "
                                      "the one kl_reference names (rollout: RLlib's). 0 = off", check=non_negative)
    kl_loss_target: float | None = option(None, "with kl_loss_coef > 0, adapt the coefficient after every update as "
                                                "RLlib does: x1.5 when the last minibatch's KL is above 2 * "
                                                "kl_loss_target, x0.5 when below kl_loss_target / 2 (None: a fixed "
                                                "coefficient)", check=positive)
    value_loss_clip: float | None = option(None, "RLlib's vf_clip_param: each sample's squared value error is "
                                                 "clamped to [0, this] (the loss, not the update, is clipped; "
                                                 "instead of clip_value's clipped update). None = off",
                                           check=positive)
    timeout_bootstrap: str = option("final_obs", "with value_bootstrap, the value a time-out bootstraps (rlchain): "
                                                 "final_obs = V(the true final observation); previous_value = "
                                                 "V(the state before the last step), as rl_games (reward += "
                                                 "gamma * V(s_t)); see docs/ppo_parity.md",
                                    choices=("final_obs", "previous_value"))
    obs_normalizer_update: str = option("auto", "with normalize_input, when the observation statistics fold "
                                                "the rollout in: rollout = all of it once before the update "
                                                "(every minibatch trains under the statistics the next rollout "
                                                "acts with); minibatch = as rl_games, each minibatch of the "
                                                "first mini-epoch just before its forward pass (the central "
                                                "value keeps rollout); auto = minibatch for continuous actions "
                                                "(measured better on Hopper, level on the other MuJoCo YAMLs, "
                                                "docs/ppo_parity.md), rollout otherwise and with multi_agent; "
                                                "step = as rsl_rl, each env step's next observations as they "
                                                "come (auto with obs_normalizer rsl_rl)",
                                        choices=("auto", "rollout", "minibatch", "step"))
    torch_compile: Any = option(False, "PPO: torch.compile the network: false, true (mode default), a mode "
                                       "(default, reduce-overhead, max-autotune) or {mode, critic_mode, "
                                       "backend}. rl_games defaults to true; rlchain to false (compiling "
                                       "costs ~30 s on a CPU)", check=check_compile)
    compile_update: bool = option(False, "PPO (rlchain): torch.compile one minibatch step's forward pass and "
                                         "losses (with the backward pass derived from them); feed-forward "
                                         "networks only. Compiling costs 5-50 s on a CPU, so it pays only "
                                         "in long runs (docs/benchmarks.md)")
    cuda_graph: Any = option("auto", "PPO (rlchain), CUDA: capture the rollout's act step and one minibatch step "
                                     "(forward, losses, backward, clipping, fused Adam) as CUDA graphs after 3 "
                                     "eager steps and replay them (docs/benchmarks.md). auto = on for rlchain's "
                                     "feed-forward networks on one GPU "
                                     "without torch_compile, compile_update or mixed_precision; True = on "
                                     "(a ConfigError where it cannot run: RNN, get_aux_loss, fp16, multi_gpu; "
                                     "a warning on a CPU); False = off",
                              check=check_cuda_graph)
    seq_length: int = option(4, "RNN: steps per training sequence; horizon_length and minibatch_size must "
                                "divide by it (the deprecated `seq_len` is read as this, with a warning)",
                             check=positive)
    bptt_length: int | None = option(None, "RNN: backpropagate through at most this many steps of a "
                                           "sequence (truncated BPTT; default: the whole seq_length)",
                                     check=positive)
    zero_rnn_on_done: bool = option(True, "RNN: zero the hidden state when an episode ends, in the rollout "
                                          "and inside training sequences")
    obs_groups: ObsGroupsConfig | None = option(None, "rlchain: the part of the observation each network sees "
                                                      "(teacher, student, critic; docs/distillation.md)")
    distilled_checkpoint: str | None = option(None, "rlchain: start from a distilled student (an algo: distill "
                                                    "checkpoint): its weights, the student's view "
                                                    "(obs_groups.policy: student); stage three of "
                                                    "docs/distillation.md")
    distilled_value: str = option("scratch", "with distilled_checkpoint, the value head: scratch (as the "
                                             "student has it, untrained) or teacher (regressed on the "
                                             "teacher's values over distilled_value_epochs rollouts first)",
                                  choices=("scratch", "teacher"))
    distilled_value_epochs: int = option(5, "with distilled_value teacher: rollouts of value regression",
                                         check=positive)
    central_value_config: CentralValueConfig | None = option(
        None, "asymmetric actor-critic: a value network on the env's `state` (env use_central_value)")
    rnd: RndConfig | None = option(None, "rlchain (rsl_rl's rnd_cfg; not rl_games' rnd_config): random network "
                                         "distillation, an intrinsic reward for novel states (docs/robot_learning.md)")
    symmetry: SymmetryConfig | None = option(None, "rlchain (rsl_rl's symmetry_cfg): mirrored samples and a "
                                                   "mirror loss from a robot's mirror map (docs/robot_learning.md)")
    use_action_masks: bool = option(False, "invalid-action masks from the env's has_action_mask() / "
                                           "get_action_mask() (discrete and multi-discrete actions)")
    self_play_config: SelfPlayConfig | None = option(None, "self-play: frozen copies of the policy as the "
                                                           "env's opponent (needs env set_opponent)")
    multi_agent: MultiAgentConfig | None = option(None, "PettingZoo agents played by several policies, each "
                                                        "with its own model and optimizer (env_name: "
                                                        "pettingzoo; docs/multi_agent.md)")

    @property
    def model_group(self) -> str:
        """The observation group PPO's model reads: the student's when starting from a distilled one, else
        ``obs_groups.policy`` (teacher by default: the whole observation without groups)."""
        if self.distilled_checkpoint:
            return "student"
        return self.obs_groups.policy if self.obs_groups is not None else "teacher"


    def with_network(self, network: Any, source: str) -> PPOConfig:
        """An RNN's sequences fit the horizon and the minibatch; the asymmetric critic's block resolved."""
        if has_rnn(network):
            self._check_sequences(source)
        if self.central_value_config is not None:
            return dataclasses.replace(self, central_value_config=self._resolve_central_value(source))
        return self

    def _check_sequences(self, source: str) -> None:
        """An RNN trains on whole sequences: horizon and minibatch must hold whole seq_length blocks."""
        length = self.seq_length
        if self.horizon_length % length:
            raise ConfigError(source, "params.config.seq_length",
                              f"horizon_length {self.horizon_length} is not divisible by seq_length {length}")
        if self.minibatch_size % length:
            raise ConfigError(source, "params.config.seq_length",
                              f"minibatch_size {self.minibatch_size} is not divisible by seq_length {length}")

    def _resolve_central_value(self, source: str) -> CentralValueConfig:
        """The asymmetric critic: value-only network, a minibatch that divides the batch. Returns the block
        with its network parsed and its minibatch_size resolved (default: the actor's)."""

        cv, path = self.central_value_config, "params.config.central_value_config"
        cv = dataclasses.replace(cv, network=parse_network(cv.network, source, f"{path}.network"))
        check_registered(NETWORKS, network_name(cv.network), f"{path}.network.name", source)
        typed = isinstance(cv.network, NetworkConfig)  # actor_critic; a user network's block is its own
        heads = [k for k in ("discrete", "multi_discrete", "continuous")
                 if typed and getattr(cv.network.space, k) is not None]
        if heads:
            raise ConfigError(source, f"{path}.network.space", f"the central value network is a critic (value "
                              f"only); remove the '{heads[0]}' action head")
        if cv.minibatch_size_per_env is not None:
            cv = dataclasses.replace(cv, minibatch_size=self.num_actors * cv.minibatch_size_per_env)
        cv = dataclasses.replace(cv, minibatch_size=cv.minibatch_size or self.minibatch_size)
        if typed and cv.network.rnn is not None:
            if cv.minibatch_size % self.seq_length or self.horizon_length % self.seq_length:
                raise ConfigError(source, f"{path}.minibatch_size", f"a recurrent critic trains on sequences: "
                                  f"minibatch_size {cv.minibatch_size} and horizon_length {self.horizon_length} "
                                  f"must divide by seq_length {self.seq_length}")
        return cv
