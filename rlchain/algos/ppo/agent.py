"""The PPO agent and its update (``a2c_continuous`` and ``a2c_discrete`` are presets of it).

It turns a filled rollout into parameter updates, written out in :meth:`PPOAgent.update` as rsl_rl writes its
``update()``: the mini-epochs, the minibatches, the loss (:func:`rlchain.algos.ppo.loss.ppo_loss`), backward,
gradient clipping, Adam's step, and the KL the adaptive lr follows. The agent *is* the optimizer with its
schedules (:class:`rlchain.algos.ppo.optimizer.ScheduledAdam`: ``optimizer``, ``lr``, ``entropy_coef``,
checkpoints), so the loop, rl_games' observers and the divergence guard read them off the agent without a
forwarder. There is no action-space branch here: the model's distribution handles that.

The minibatch step runs one of three ways (:attr:`PPOAgent.mode`): eagerly, with the loss compiled
(``compile_update``), or as a captured CUDA graph (``cuda_graph``, rlchain.algos.ppo.graph_step).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from functools import partial
from typing import ClassVar

import numpy as np
import torch

from rlchain.algos.base.safety import UpdateInterrupted
from rlchain.algos.core.advantage_stats import MovingAdvantageStats
from rlchain.algos.core.losses import normalize_advantages, policy_loss
from rlchain.algos.core.optimizer_step import check_finite, optimizer_step
from rlchain.algos.core.precision import autocast_dtype
from rlchain.algos.core.storage import Batch, RolloutStorage
from rlchain.algos.ppo.graph_step import GraphedStep, zero_non_finite_
from rlchain.algos.ppo.loss import Surrogate, adapted_kl_coef, named_stats, ppo_loss, stats_vector
from rlchain.algos.ppo.optimizer import ScheduledAdam
from rlchain.algos.ppo.rllib_batch import BOOTSTRAP, batch_rows, cyclic_minibatches, rllib_standardized
from rlchain.config.ppo import PPOConfig
from rlchain.log import get_logger
from rlchain.models.actor_critic import ActorCritic
from rlchain.parallel.communicator import SINGLE, Communicator

_log = get_logger(__name__)


class PPOAgent(ScheduledAdam):
    """Clipped-surrogate PPO with value clipping, entropy and bounds losses, adaptive/linear/polynomial lr.

    ``lr`` and ``entropy_coef`` are the live values (the schedules, population-based training and divergence
    rollbacks change them; :class:`~rlchain.algos.ppo.optimizer.ScheduledAdam`) and travel in
    :meth:`state_dict`, so a resumed run goes on with the values the interrupted one had; ``cfg`` keeps the
    configured start values. ``optimizer`` is torch's Adam (rl_games' observers read it).

    ``train_critic`` False (a central value network trains the values) leaves the value loss out;
    ``should_stop`` is checked between minibatches (a stop signal: :class:`UpdateInterrupted`). A network
    with ``get_aux_loss()`` (rl_games' contract) has its auxiliary losses added to the loss after each forward
    pass; they come back from :meth:`update` as ``losses/<name>``.

    Subclasses change :attr:`surrogate` (IMPALA), :meth:`_batch_advantages` and :meth:`_minibatches`
    (the multi-policy agent's active steps).
    """

    surrogate: ClassVar[Surrogate] = staticmethod(policy_loss)
    """Per-sample policy loss (B,) of (rollout log-probs, log-probs, advantages, e_clip, smooth clamp)."""
    kl_adapt_each_pass: ClassVar[bool] = False
    """The KL penalty's coefficient adapts after every pass over the batch (RLlib's APPO, whose learner updates
    once per pass) instead of once after the whole update (RLlib's PPO)."""

    def __init__(self, model: ActorCritic, cfg: PPOConfig, device: torch.device, comm: Communicator = SINGLE,
                 cuda_graph: bool = False, train_critic: bool = True,
                 should_stop: Callable[[], bool] | None = None) -> None:
        # mixed_precision: bf16 autocast, no scaler (rl_games 2.0; on a CPU with native bf16 too); fp16
        # autocast with a GradScaler (1.6, CUDA)
        self.amp_dtype = autocast_dtype(cfg.mixed_precision, device)
        super().__init__([p for p in model.parameters() if p.requires_grad], cfg, device, comm,
                         capturable=cuda_graph, grad_scaler=self.amp_dtype == torch.float16)
        self.model, self.cfg, self.device = model, cfg, device
        self.train_critic = train_critic
        self.should_stop = should_stop
        self.losses = ppo_loss  # compile() swaps in the compiled region
        self._compile_pending = False
        # cuda_graph (resolved by rlchain.algos.ppo.graph_step.resolve_cuda_graph): the step as a captured graph
        self.graphed = GraphedStep(self._sync_free_step, self.clear_grads) if cuda_graph else None
        self._aux_names: tuple[str, ...] = ()
        self._max_norm = float("inf")  # the graphed step's clip (a Python constant in the graph)
        # rl_games 2.0: advantages normalized by moving statistics instead of the batch's own
        self.advantage_stats = MovingAdvantageStats(cfg.adv_rms_momentum, device) \
            if cfg.normalize_advantage and cfg.normalize_rms_advantage else None
        # RLlib's KL penalty: the live coefficient (kl_target adapts it after every update), one persistent tensor
        # (PPOConfig's and APPOConfig's keys; IMPALA's config has none: off)
        self.kl_coef = getattr(cfg, "kl_loss_coef", 0.0)
        self._kl_coef_t = torch.tensor(float(self.kl_coef), device=device) if self.kl_coef > 0 else None
        # advantage_normalization rllib: the raw advantages of RLlib's bootstrap rows for this update (PPO sets them)
        self.bootstrap_advantages: np.ndarray | None = None
        self.last_minibatch_stats: dict[str, float] = {}  # the last update's last minibatch (RLlib's window=1)

    @property
    def mode(self) -> str:
        """How the minibatch step runs: ``graphed``, ``compiled`` or ``eager``."""
        if self.graphed is not None:
            return "graphed"
        return "compiled" if self.losses is not ppo_loss else "eager"

    def compile(self) -> None:
        """``compile_update``: from now on the loss runs as one compiled region, with static shapes where the
        minibatch size divides the batch (every minibatch the same shape); RLlib's cyclic minibatches
        (``minibatch_order: rllib``) leave out a varying number of masked rows, so there the row count is
        dynamic rather than one compile per count. The compile happens on the first minibatch; its seconds
        are logged."""
        self.losses = torch.compile(ppo_loss, dynamic=None if self.cfg.minibatch_order == "rllib" else False)
        self._compile_pending = True

    # ----- the update -------------------------------------------------------------------------
    def update(self, storage: RolloutStorage, progress: float, obs_per_minibatch: bool = False,
               bootstrap_advantages: np.ndarray | None = None) -> dict[str, float]:
        """Run ``mini_epochs`` passes of minibatch updates; return mean losses, kl and lr.

        Each minibatch: the loss, backward, gradient averaging over ranks, unscaling (float16), clipping and
        Adam, with one host sync to read the statistics; a non-finite statistic raises DivergenceError before
        the step (with a grad scaler the scaler skips inf steps itself). Auxiliary losses of the network
        appear as ``losses/<name>``, averaged over the minibatches that returned them. ``obs_per_minibatch``
        (``obs_normalizer_update: minibatch``): each minibatch of the first pass folds its observations into
        the input statistics just before its forward pass, as rl_games' training forward does (the caller
        has not folded the rollout in). ``bootstrap_advantages`` (``advantage_normalization: rllib``): the
        advantages of RLlib's masked bootstrap rows, which its standardization counts too.
        """
        cfg, model = self.cfg, self.model
        self.bootstrap_advantages = bootstrap_advantages
        advantages = self._batch_advantages(storage)
        sums = {"a_loss": 0.0, "c_loss": 0.0, "entropy": 0.0, "b_loss": 0.0, "kl": 0.0, "clip_frac": 0.0,
                "grad_norm": 0.0}
        count, aux_counts = 0, {}  # aux_counts: minibatches per losses/<name>
        reference = self._kl_reference(storage)
        max_norm = cfg.grad_norm if cfg.truncate_grads else float("inf")
        for mini_epoch, minibatches in enumerate(self._passes(storage, advantages)):
            epoch_kl, epoch_n = 0.0, 0
            for batch in minibatches:
                if obs_per_minibatch and mini_epoch == 0:
                    with torch.no_grad():
                        model.update_normalizers(obs=batch.obs)
                if self.should_stop is not None and self.should_stop():
                    raise UpdateInterrupted
                coef = self.entropy_coef_tensor()
                # the KL against the rollout's policy, or (kl_reference previous) the policy of the last pass
                previous = batch.params if reference is None else reference.index_select(0, batch.index)
                if self.graphed is not None:
                    stats = self._graph_step(batch, coef, previous, reference, max_norm)
                else:
                    start = time.perf_counter()
                    loss, stats_t, aux, current = self.losses(
                        model, cfg, batch, coef, previous, self.surrogate, self.train_critic, self.amp_dtype,
                        self.device.type, kl_coef=self._kl_coef_t)
                    if self._compile_pending:
                        self._compile_pending = False
                        _log.info(f"compile_update: compiled the PPO minibatch step in "
                                  f"{time.perf_counter() - start:.1f} s")
                    if reference is not None:  # the next pass measures the KL against the policy this one saw
                        reference.index_copy_(0, batch.index, current)
                    stats = optimizer_step(self.optimizer, loss, params=self.params, max_norm=max_norm,
                                           comm=self.comm, scaler=self.scaler, what="the PPO update",
                                           stats=partial(read_stats, loss, stats_t, aux))
                for key, value in stats.items():
                    if key == "loss":  # the minibatch's total loss: kept for the last minibatch only (RLlib's)
                        continue
                    sums[key] = sums.get(key, 0.0) + value
                    if key.startswith("losses/"):  # auxiliary: averaged over the minibatches that had it
                        aux_counts[key] = aux_counts.get(key, 0) + 1
                count += 1
                epoch_kl += stats["kl"]
                epoch_n += 1
                if cfg.schedule_type == "legacy":
                    self.follow_kl(stats["kl"])
            if cfg.schedule_type == "standard":
                self.follow_kl(epoch_kl / max(epoch_n, 1))
            if self.kl_adapt_each_pass and epoch_n:
                self._adapt_kl_coef(stats["kl"])
        self.last_minibatch_stats = stats if count else {}  # the update's last minibatch (RLlib reports those)
        self.apply_progress(progress)
        if not self.kl_adapt_each_pass and count:
            self._adapt_kl_coef(stats["kl"])
        out = {key: value / max(aux_counts.get(key, count), 1) for key, value in sums.items()}
        out["lr"] = self.lr
        out["entropy_coef"] = self.entropy_coef
        if self._kl_coef_t is not None:
            out["kl_coef"] = self.kl_coef
        return out

    def _adapt_kl_coef(self, kl: float) -> None:
        """The KL penalty's coefficient after a step whose KL was ``kl``, when it adapts (``kl_loss_target``)."""
        target = getattr(self.cfg, "kl_loss_target", None)
        if self._kl_coef_t is not None and target is not None:
            self.kl_coef = adapted_kl_coef(self.kl_coef, kl, target)
            self._kl_coef_t.fill_(self.kl_coef)

    def _batch_advantages(self, storage: RolloutStorage) -> torch.Tensor:
        """The (T, N) advantages the update trains on: value heads summed (as in rl_games), then
        normalized over the whole batch once when ``normalize_advantage`` (``advantage_normalization:
        minibatch``: in each minibatch's loss instead)."""
        advantages = storage.advantages.sum(-1)
        if self.advantage_stats is not None:
            return self.advantage_stats.normalize(advantages)
        if self.cfg.normalize_advantage and self.cfg.advantage_normalization == "batch":
            advantages = normalize_advantages(advantages)
        elif self.cfg.normalize_advantage and self.cfg.advantage_normalization == "rllib":
            if self.bootstrap_advantages is None:
                raise RuntimeError("advantage_normalization rllib: the update needs the bootstrap rows' "
                                   "advantages (PPO passes them to update())")
            advantages = rllib_standardized(advantages, self.bootstrap_advantages)
        return advantages

    def _passes(self, storage: RolloutStorage, advantages: torch.Tensor) -> Iterator[Iterator[Batch]]:
        """The update's passes, each an iterator of its minibatches: ``mini_epochs`` passes of
        :meth:`_minibatches`, or (``minibatch_order: rllib``, a feed-forward policy) RLlib's cyclic minibatches
        over its train batch's rows, its masked bootstrap rows left out of each minibatch (RLlib's loss is the
        mean over the real rows; rlchain.algos.ppo.rllib_batch), grouped by the pass each starts in."""
        cfg = self.cfg
        own_picks = type(self)._minibatches is not PPOAgent._minibatches  # the multi-policy agent's active steps
        if cfg.minibatch_order != "rllib" or self.model.is_rnn or own_picks:
            for _ in range(cfg.mini_epochs):
                yield self._minibatches(storage, advantages)
            return
        rows = batch_rows(storage.dones.cpu().numpy())
        device = storage.dones.device
        for group in cyclic_minibatches(len(rows), cfg.minibatch_size, cfg.mini_epochs):
            picked = [rows[positions] for positions in group]
            yield (storage.rows_batch(torch.as_tensor(real[real != BOOTSTRAP], device=device), advantages)
                   for real in picked if (real != BOOTSTRAP).any())

    def _kl_reference(self, storage: RolloutStorage) -> torch.Tensor | None:
        """With ``kl_reference: previous``, a (T * N, param_size) copy of the rollout's distribution
        parameters that the update measures the KL against and then overwrites with the policy it
        saw, so from the second pass on the KL is how far the policy moved since that sample's
        previous minibatch (rl_games' continuous agent). None: the KL is against the rollout policy."""
        mode = self.cfg.kl_reference
        if mode == "auto":
            mode = "previous" if self.model.dist.continuous else "rollout"
        if mode == "rollout":
            return None
        return storage.params.reshape(-1, storage.params.shape[-1]).clone()

    def _minibatches(self, storage: RolloutStorage, advantages: torch.Tensor) -> Iterator[Batch]:
        """Flat minibatches, or whole sequences of seq_length steps for an RNN policy, in ``minibatch_order``."""
        cfg = self.cfg
        shuffle = shuffled_minibatches(cfg.minibatch_order, self.model.dist.continuous)
        if self.model.is_rnn:
            return storage.sequence_minibatches(cfg.minibatch_size, cfg.seq_length, advantages,
                                                use_resets=cfg.zero_rnn_on_done, shuffle=shuffle)
        return storage.minibatches(cfg.minibatch_size, advantages, shuffle=shuffle)

    # ----- cuda_graph: the minibatch step as a captured graph -----------------------------------
    def _sync_free_step(self, batch: Batch, coef: torch.Tensor, previous: torch.Tensor
                        ) -> tuple[torch.Tensor, torch.Tensor]:
        """The minibatch step ``cuda_graph`` captures: losses, backward, clip, Adam, with no host sync.

        Returns (the statistics of :data:`rlchain.algos.ppo.loss.STEP_STATS` then the auxiliary losses, as one
        float32 vector; the policy's params). The gradients must be None or zero on entry (the eager warm-up
        sets them to None; in the graph backward writes the graph's own). A non-finite statistic zeroes the
        gradients and this step's lr, so the parameters stay as they were and the caller raises on the
        statistics.
        """
        loss, stats_t, aux, current = self.losses(self.model, self.cfg, batch, coef, previous, self.surrogate,
                                                  self.train_critic, self.amp_dtype, self.device.type,
                                                  autocast_cache=False, kl_coef=self._kl_coef_t)
        loss.backward()
        values = stats_vector(loss, stats_t, aux, torch.nn.utils.clip_grad_norm_(self.params, self._max_norm,
                                                                                 foreach=True))
        finite = torch.isfinite(values).all()
        zero_non_finite_(finite, self.params)
        self.lr_step.copy_(self.lr_live * finite)
        self.optimizer.step()
        self._aux_names = tuple(aux)
        return values, current

    def _graph_step(self, batch: Batch, coef: torch.Tensor, previous: torch.Tensor,
                    reference: torch.Tensor | None, max_norm: float) -> dict[str, float]:
        """The step through the captured graph: the same statistics, one host sync to read them."""
        self._max_norm = max_norm
        values, current = self.graphed(batch, coef, previous)
        if reference is not None:
            reference.index_copy_(0, batch.index, current)
        stats = named_stats(values.tolist(), self._aux_names)
        check_finite(stats, "the PPO update")  # a non-finite step left the parameters as they were
        return stats

    # ----- live values and checkpoints ----------------------------------------------------------
    def config_changed(self) -> None:
        """A value of ``cfg`` changed (population-based training): a captured step holds the old one as a
        constant, so it is recorded again."""
        if self.graphed is not None:
            self.graphed.reset()

    def state_dict(self) -> dict:
        """Optimizer state, live lr and entropy coefficient (:meth:`ScheduledAdam.state_dict`), and the moving
        advantage statistics under rl_games' ``advantage_mean_std`` when ``normalize_rms_advantage``."""
        state = super().state_dict()
        if self.advantage_stats is not None:
            state["advantage_mean_std"] = self.advantage_stats.state_dict()
        if self._kl_coef_t is not None:
            state["kl_coef"] = self.kl_coef
        return state

    def load_state_dict(self, state: dict) -> None:
        """Restore :meth:`state_dict`; new optimizer state tensors: a captured step is recorded again."""
        state = dict(state)
        advantage_stats = state.pop("advantage_mean_std", None)
        kl_coef = state.pop("kl_coef", None)
        if self._kl_coef_t is not None and kl_coef is not None:
            self.kl_coef = float(kl_coef)
            self._kl_coef_t.fill_(self.kl_coef)
        if self.advantage_stats is not None and advantage_stats is not None:
            self.advantage_stats.load_state_dict(advantage_stats)
        super().load_state_dict(state)
        self.config_changed()


def read_stats(loss: torch.Tensor, stats: torch.Tensor, aux: dict[str, torch.Tensor],
               grad_norm: torch.Tensor) -> dict[str, float]:
    """An eager step's statistics read back by name (its one host sync)."""
    return named_stats(stats_vector(loss, stats, aux, grad_norm).tolist(), aux)


def shuffled_minibatches(order: str, continuous: bool) -> bool:
    """``minibatch_order`` resolved: True for a new permutation every mini-epoch, False for rl_games'
    fixed env-major blocks (``auto``: fixed for continuous actions, shuffled otherwise; ``rllib``: shuffled where
    RLlib's cyclic order does not apply, an RNN's sequences and a central value's minibatches)."""
    return order in ("shuffle", "rllib") or (order == "auto" and not continuous)
