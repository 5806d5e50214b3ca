"""An RLlib ``IMPALAConfig`` / ``APPOConfig`` -> the rlchain ``impala`` / ``appo`` config that trains it.

What maps (RLlib 2.60's defaults in brackets):

- the runners: ``num_env_runners`` (2) runners of ``num_envs_per_env_runner`` (1) envs sample fragments of
  ``rollout_fragment_length`` (50) steps -> rlchain's runners (threads, or Ray actors:
  :mod:`rlchain.rllib.env_runners`) and ``horizon_length``; the learner's batch is ``train_batch_size`` (500)
  env steps: rlchain's batch is one fragment of every env, so each runner holds as many envs as it takes
  (500 / (2 x 50): 5 envs each, 10 fragments of 50 per batch, as RLlib gathers 10);
- ``vtrace_clip_rho_threshold`` (1.0) -> ``appo.vtrace_clip_rho``; the trace's c-bar is 1.0, as RLlib's;
  ``learner_queue_size``, ``broadcast_interval``; stale fragments are kept (RLlib drops none):
  ``appo.max_policy_lag`` 100;
- ``lr`` (5e-4) -> a constant ``learning_rate``; ``grad_clip`` (40, global norm) -> ``grad_norm``;
  ``vf_loss_coeff`` (0.5) -> ``critic_coef`` (both sides' value loss is 0.5 x coefficient x squared error);
  ``entropy_coeff`` (0.01) -> ``entropy_coef``; ``gamma``; no advantage standardization (RLlib has none);
  ``minibatch_size`` (the whole batch) and ``num_epochs`` (1);
- APPO: ``clip_param`` (0.4) -> ``e_clip``; its circular buffer trains every batch
  ``circular_buffer_iterations_per_batch`` (2) times -> ``mini_epochs``;
- APPO's ``use_kl_loss`` with ``kl_coeff`` (1.0) and ``kl_target`` (0.01) -> ``kl_loss_coef`` / ``kl_loss_target``:
  the penalty against a target policy, its coefficient adapted after every pass; RLlib refreshes its target
  network every ``target_network_update_freq`` (2) x ``circular_buffer_num_batches`` (8) x
  ``circular_buffer_iterations_per_batch`` x train batch env steps trained -> ``target_update_interval``
  learner updates (each trains ``mini_epochs`` x its batch);
- ``use_lstm`` / ``lstm_cell_size`` / ``max_seq_len`` -> an rnn block (as for PPO) and ``seq_length``: the longest
  sequence not above ``max_seq_len`` that tiles the fragment (50 and 20: 10), each starting from the RNN state its
  runner had there (RLlib pads the fragment's last chunk instead).

What does not: ``vtrace=False``, a ``vtrace_clip_pg_rho_threshold`` other than ``vtrace_clip_rho_threshold``
(rlchain clips both ratios with one rho-bar), ``tau`` other than 1 with ``use_kl_loss``: each a one-line error.
APPO's ratio and V-trace are against the behaviour policy (RLlib's against its target network, clipped by
``target_worker_clipping``): that key is kept and has no effect.
"""

from __future__ import annotations

import math
from typing import Any

from rlchain.rllib import translate as T
from rlchain.rllib.env_runners import env_runners_block, uses_ray
from rlchain.rllib.networks import actor_critic_network
from rlchain.rllib.obs_filter import filter_keys


def _fragment(config: Any) -> int:
    value = config._settings.get("rollout_fragment_length")
    if value in (None, "auto"):
        return 50
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise T._bad(config, "rollout_fragment_length", f"expected a whole number > 0 or 'auto', got {value!r}")
    return value


def vtrace_config(config: Any, env_name: str, obs_space: Any, continuous: bool, run: dict[str, Any]
                  ) -> dict[str, Any]:
    """The rlchain ``appo`` (APPOConfig) or ``impala`` (IMPALAConfig) config on ``env_name`` (see the module
    docstring)."""
    T.check_supported(config)
    s = config._settings
    appo = config.algo_name == "APPO"
    if not s.get("vtrace", True):
        raise T._bad(config, "vtrace", "False is not offered: rlchain's APPO and IMPALA learn with V-trace")
    rho, pg_rho = s.get("vtrace_clip_rho_threshold"), s.get("vtrace_clip_pg_rho_threshold")
    if pg_rho != rho:
        raise T._bad(config, "vtrace_clip_pg_rho_threshold", f"{pg_rho!r} differs from vtrace_clip_rho_threshold "
                                                             f"{rho!r}: rlchain clips both ratios with one rho-bar")
    kl_on = appo and bool(s.get("use_kl_loss")) and float(s.get("kl_coeff") or 0.0) > 0
    if kl_on and s.get("tau") not in (None, 1, 1.0):
        raise T._bad(config, "tau", f"{s.get('tau')!r} is not offered with use_kl_loss: rlchain's APPO copies the "
                                    f"learner's policy into the KL's target policy whole (tau 1.0)")
    for key in ("lr", "entropy_coeff"):
        if isinstance(s.get(key), (list, tuple)):
            raise T._bad(config, key, "a schedule list is not mapped: a constant")
    block = env_runners_block(config)
    runners, per_runner = block["num_workers"], block["envs_per_worker"]
    fragment = _fragment(config)
    batch = config.total_train_batch_size
    per_runner = max(per_runner, math.ceil(batch / (runners * fragment)))
    block["envs_per_worker"] = per_runner
    envs = runners * per_runner
    frames = envs * fragment
    network, max_seq_len = actor_critic_network(config, obs_space, continuous)
    # an LSTM trains on sequences that tile the fragment: the longest not above max_seq_len
    seq = max(d for d in range(1, min(max_seq_len, fragment) + 1) if fragment % d == 0) if max_seq_len else 1
    minibatch = s.get("minibatch_size") or frames
    minibatch = min(int(minibatch), frames)
    while frames % minibatch or minibatch % seq:  # whole minibatches (of whole sequences): the nearest smaller
        minibatch -= 1
    grad_clip = s.get("grad_clip")
    train = {
        "env_name": env_name, "num_actors": envs, "horizon_length": fragment, "minibatch_size": minibatch,
        "learning_rate": float(s["lr"]), "lr_schedule": None, "gamma": float(s["gamma"]),
        "critic_coef": float(s["vf_loss_coeff"]), "entropy_coef": float(s.get("entropy_coeff") or 0.0),
        "grad_norm": float(grad_clip) if grad_clip is not None else 1.0, "truncate_grads": grad_clip is not None,
        "normalize_advantage": False, "normalize_input": False, "normalize_value": False, "value_bootstrap": True,
        "reward_shaper": {"scale_value": 1.0}, "env_runners": block,
        "appo": {"vtrace_clip_rho": None if rho is None else float(rho), "vtrace_clip_c": 1.0,
                 "max_policy_lag": 100, "learner_queue_size": max(1, int(s.get("learner_queue_size") or 16)),
                 "broadcast_interval": max(1, int(s.get("broadcast_interval") or 1)),
                 "runners": "ray" if uses_ray(config) else "local"},
        "games_to_track": int(s.get("metrics_num_episodes_for_smoothing") or 100),
        "save_best_after": 10**9, "score_to_win": float("inf"), "max_epochs": -1,
    }
    if appo:
        passes = s.get("circular_buffer_iterations_per_batch") if s.get("use_circular_buffer", True) \
            else s.get("num_epochs")
        passes = max(1, int(passes or 1))
        train.update({"e_clip": float(s["clip_param"]), "clip_value": False, "mini_epochs": passes})
        if kl_on:  # RLlib refreshes its target network every freq * N * K * train batch env steps trained
            trained = int(s.get("target_network_update_freq") or 1) * int(s.get("circular_buffer_num_batches") or 1) \
                * int(s.get("circular_buffer_iterations_per_batch") or 1) * batch
            train.update({"kl_loss_coef": float(s["kl_coeff"]), "kl_loss_target": float(s["kl_target"]),
                          "target_update_interval": max(1, round(trained / (passes * frames)))})
    elif int(s.get("num_epochs") or 1) != 1:
        raise T._bad(config, "num_epochs", f"{s.get('num_epochs')!r}: rlchain's IMPALA makes one pass per batch "
                                           f"(APPOConfig makes several)")
    if max_seq_len:
        train["seq_length"] = seq
    train.update(filter_keys(config))  # RLlib's MeanStdFilter connector: the learner's observation normalizer
    train.update(run)
    algo, model = ("appo" if appo else "impala"), ("continuous_a2c_logstd" if continuous else "discrete_a2c")
    params = {"algo": {"name": algo}, "model": {"name": model}, "network": network, "config": train}
    if s.get("seed") is not None:
        params["seed"] = int(s["seed"])
    return {"params": params}
