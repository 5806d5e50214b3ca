"""Typed ``params.config`` for the asynchronous algorithms ``appo`` and ``impala`` (V-trace).

They train the PPO model with the PPO agent's optimizer, normalizers and lr schedules, so they share
:class:`~rlchain.config.actor_critic.ActorCriticConfig`'s keys with PPO, with the same meaning;
``horizon_length`` is the length of a runner's trajectory fragment and one epoch is one learner batch of
``num_actors * horizon_length`` frames. ``appo`` adds PPO's clipped-surrogate keys, ``impala`` fixes them.
A key of PPO that they do not read (``tau``, ``env_groups``, ...) is ignored with a one-line warning that
says why (``other_algo_keys``, see :mod:`rlchain.config.algo_keys`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from rlchain.config.actor_critic import ActorCriticConfig
from rlchain.config.errors import ConfigError
from rlchain.config.fields import option, positive, variant
from rlchain.config.network_block import has_rnn
from rlchain.config.ppo import PPOConfig


def _clip(x: float | None) -> str | None:
    return None if x is None or x > 0 else "must be > 0 (or None: no clipping)"


@dataclass(frozen=True)
class AppoBlock:
    """``config.appo``: the asynchronous actor-learner (runners wait for the learner only when its queue is full)."""

    vtrace_clip_rho: float | None = option(1.0, "V-trace rho-bar: clip of the importance ratio pi/mu in the TD "
                                                "errors (None: no clipping)", check=_clip)
    vtrace_clip_c: float | None = option(1.0, "V-trace c-bar: clip of the trace ratios (None: no clipping)",
                                         check=_clip)
    max_policy_lag: int = option(4, "fragments sampled by a policy more than this many versions behind the "
                                    "learner's are dropped and counted (appo/dropped_fragments)",
                                 check=lambda x: None if x >= 0 else "must be >= 0")
    learner_queue_size: int = option(16, "fragments waiting for the learner at most; full, runners wait "
                                         "(backpressure, bounded memory)", check=positive)
    broadcast_interval: int = option(1, "send the runners new weights every this many learner updates",
                                     check=positive)
    runners: str = option("auto", "local: runner threads in this process; ray: Ray actors (env_runners.address "
                                  "names a cluster); auto: ray when env_runners.address or RAY_ADDRESS is set, "
                                  "else local", choices=("auto", "local", "ray"))
    fragment_timeout_s: float = option(60.0, "a runner that delivers no fragment within this is treated as "
                                             "hung and replaced (env_runners.max_restarts)", check=positive)


RNN_NOTE = "the runners always zero an RNN's state where an episode ends, and train whole seq_length sequences"


@dataclass(frozen=True)
class VTraceConfig(ActorCriticConfig):
    """The keys ``appo`` and ``impala`` share: the actor-critic keys and the asynchronous learner's block."""

    appo: AppoBlock = option(AppoBlock(), "the asynchronous learner (rlchain)")
    seq_length: int = variant(PPOConfig, "seq_length", doc="RNN: steps per training sequence (each starts from the "
                                                           "state its runner had there); horizon_length (the "
                                                           "fragment) and minibatch_size must divide by it")

    # Not keys: the fixed values of features the runners do not have, read by the PPO agent and model they
    # share with PPO. A YAML key of one of these names is PPO's, ignored here with the warning below.
    use_action_masks: ClassVar[bool] = False
    bptt_length: ClassVar[int | None] = None
    zero_rnn_on_done: ClassVar[bool] = True
    central_value_config: ClassVar[Any] = None
    self_play_config: ClassVar[Any] = None
    torch_compile: ClassVar[Any] = False
    compile_update: ClassVar[bool] = False
    cuda_graph: ClassVar[bool] = False
    env_groups: ClassVar[int] = 1

    other_algo_keys: ClassVar[dict[str, str]] = {
        "tau": "it is GAE's lambda; V-trace's trace is cut by appo.vtrace_clip_c",
        "env_groups": "runners step their envs on their own",
        "central_value_config": "no asymmetric critic for the asynchronous learner yet",
        "self_play_config": "no self-play for the asynchronous learner yet",
        "use_action_masks": "the runners carry no action masks yet",
        "bptt_length": RNN_NOTE, "zero_rnn_on_done": RNN_NOTE,
        "torch_compile": "supported for PPO only so far",
        "compile_update": "supported for PPO only so far",
        "cuda_graph": "supported for PPO only so far",
        "timeout_bootstrap": "a time-out always bootstraps V(the true final observation)",
        "obs_normalizer_update": "the learner folds each whole batch into the statistics before its update",
    }
    """Why this algorithm ignores a key of another algorithm (added to the warning)."""

    def validate(self) -> tuple[str, str] | None:
        """Every runner holds the same number of envs, so every fragment has the same shape; PPO's RLlib
        standardization needs PPO's rollout."""
        if self.normalize_advantage and self.advantage_normalization == "rllib":  # else it fails at the update
            return "advantage_normalization", ("rllib is PPO's (RLlib's bootstrap rows, one per episode chunk of "
                                               "PPO's rollout): batch or minibatch here, or normalize_advantage "
                                               "False (RLlib's APPO and IMPALA standardize nothing)")
        appo = self.appo
        if appo.max_policy_lag < appo.broadcast_interval - 1:  # every fragment would be too old: no progress
            return "appo.max_policy_lag", (f"{appo.max_policy_lag} is below broadcast_interval - 1 = "
                                           f"{appo.broadcast_interval - 1}: runners hold weights that many versions "
                                           f"old between broadcasts, so every fragment would be dropped")
        runners = self.env_runners
        if runners is not None and runners.num_workers is not None and self.num_actors % runners.num_workers:
            return "env_runners.num_workers", (f"num_actors {self.num_actors} does not divide by {runners.num_workers} "
                                               f"workers: appo/impala runners need equal env slices")
        return None  # the minibatch against the batch: check_batch, once the env's agents are known

    def with_network(self, network: Any, source: str) -> VTraceConfig:
        """An RNN trains on whole sequences: the fragment and the minibatch must hold whole seq_length blocks."""
        if has_rnn(network):
            for key in ("horizon_length", "minibatch_size"):
                if getattr(self, key) % self.seq_length:
                    raise ConfigError(source, "params.config.seq_length", f"{key} {getattr(self, key)} is not "
                                      f"divisible by seq_length {self.seq_length}")
        return self


@dataclass(frozen=True)
class APPOConfig(VTraceConfig):
    """``params.config`` for algo ``appo``: PPO's clipped surrogate on V-trace advantages, several SGD passes
    (``mini_epochs``) per learner batch."""

    # words for its heading in docs/config.md
    doc_note: ClassVar[str] = ("asynchronous PPO on V-trace, docs/appo.md; keys shared with PPO have the same "
                               "meaning, horizon_length is the fragment length; a PPO key not listed here, e.g. "
                               "tau, is ignored with a warning")

    mini_epochs: int = variant(PPOConfig, "mini_epochs")
    e_clip: float = variant(PPOConfig, "e_clip")
    clip_value: bool = variant(PPOConfig, "clip_value")
    use_smooth_clamp: bool = variant(PPOConfig, "use_smooth_clamp")
    kl_loss_coef: float = variant(PPOConfig, "kl_loss_coef", doc="KL penalty (RLlib's APPO use_kl_loss / kl_coeff): "
                                  "loss += kl_loss_coef * mean KL(target policy || current policy), with its "
                                  "gradient; the target policy is a frozen copy of the learner's, refreshed every "
                                  "target_update_interval updates (kl_reference does not apply). 0 = off")
    kl_loss_target: float | None = variant(PPOConfig, "kl_loss_target", doc="with kl_loss_coef > 0, adapt the "
                                           "coefficient after every pass over a batch as RLlib's APPO does after "
                                           "every update: x1.5 when the pass's last minibatch KL is above 2 * "
                                           "kl_loss_target, x0.5 when below kl_loss_target / 2 (None: fixed)")
    target_update_interval: int = option(1, "with kl_loss_coef > 0: learner updates between refreshes of the KL "
                                            "penalty's target policy (RLlib's target network); 1 = the policy "
                                            "before each update", check=positive)


@dataclass(frozen=True)
class ImpalaConfig(VTraceConfig):
    """``params.config`` for algo ``impala``: the V-trace actor-critic (policy gradient weighted by the clipped
    ratio, no surrogate clipping), one pass over each learner batch."""

    # words for its heading in docs/config.md
    doc_note: ClassVar[str] = ("the V-trace actor-critic, docs/appo.md; as algo appo without its clipped-"
                               "surrogate keys: one pass per batch")

    # Not keys: IMPALA's fixed values of appo's surrogate keys (e_clip only sizes the clip_frac diagnostic)
    mini_epochs: ClassVar[int] = 1
    e_clip: ClassVar[float] = 0.2
    clip_value: ClassVar[bool] = False
    use_smooth_clamp: ClassVar[bool] = False

    other_algo_keys: ClassVar[dict[str, str]] = {
        **VTraceConfig.other_algo_keys,
        "e_clip": "impala has no clipped surrogate (use algo appo)",
        "clip_value": "impala has no value clipping (use algo appo)",
        "use_smooth_clamp": "impala has no clipped surrogate (use algo appo)",
        "mini_epochs": "impala makes one pass over each batch (use algo appo for several)",
    }
