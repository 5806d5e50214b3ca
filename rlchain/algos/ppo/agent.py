"""The on-policy PPO agent (``a2c_continuous`` and ``a2c_discrete`` are presets of it).

It turns a filled rollout into parameter updates: the minibatches and mini-epochs, the KL the adaptive lr
follows. Its parts: the loss (:mod:`rlchain.algos.ppo.loss`), the optimizer and schedules
(:mod:`rlchain.algos.ppo.optimizer`) and the minibatch step that runs eagerly, compiled or as a CUDA graph
(:mod:`rlchain.algos.ppo.minibatch_step`). There is no action-space branch here: the model's distribution handles
that.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import torch

from rlchain.algos.base.safety import UpdateInterrupted
from rlchain.algos.core.advantage_stats import MovingAdvantageStats
from rlchain.algos.core.losses import normalize_advantages, policy_loss
from rlchain.algos.core.precision import autocast_dtype
from rlchain.algos.core.storage import Batch, RolloutStorage
from rlchain.algos.ppo.loss import LossOutput, ppo_loss
from rlchain.algos.ppo.minibatch_step import MinibatchStep
from rlchain.algos.ppo.optimizer import ScheduledAdam
from rlchain.config.ppo import PPOConfig
from rlchain.models.actor_critic import ActorCritic
from rlchain.parallel.communicator import SINGLE, Communicator


class PPOAgent:
    """Clipped-surrogate PPO with value clipping, entropy and bounds losses, adaptive/linear/polynomial lr.

    ``lr`` and ``entropy_coef`` are the live values (the schedules, population-based training and divergence
    rollbacks change them; :class:`~rlchain.algos.ppo.optimizer.ScheduledAdam` holds them) and travel in
    :meth:`state_dict`, so a resumed run goes on with the values the interrupted one had; ``cfg`` keeps the
    configured start values. ``optimizer`` is torch's Adam (rl_games' observers read it).

    A network with ``get_aux_loss()`` (rl_games' contract) has its auxiliary losses added to the
    loss after each forward pass; they come back from :meth:`update` as ``losses/<name>``.

    Subclasses change :meth:`surrogate` (IMPALA), :meth:`_batch_advantages` and :meth:`_minibatches`
    (the multi-policy agent's active steps).
    """

    def __init__(self, model: ActorCritic, cfg: PPOConfig, device: torch.device,
                 comm: Communicator = SINGLE, cuda_graph: bool = False) -> None:
        self.model = model
        self.comm = comm  # multi_gpu: gradients and the KL behind the adaptive lr are averaged over ranks
        self.cfg = cfg
        self.device = device
        self.should_stop: Callable[[], bool] | None = None  # checked between minibatches (a stop signal)
        self.params = [p for p in model.parameters() if p.requires_grad]
        self.graphed = cuda_graph  # resolved by the trainer (rlchain.algos.ppo.graph_step.resolve_cuda_graph)
        self.train_critic = True  # False with a central value network (it trains the values itself)
        model.bptt_length = cfg.bptt_length
        # mixed_precision: bf16 autocast, no scaler (rl_games 2.0; on a CPU with native bf16 too); fp16
        # autocast with a GradScaler (1.6, CUDA)
        self.amp_dtype = autocast_dtype(cfg.mixed_precision, device)
        self.amp = self.amp_dtype is not None
        self.adam = ScheduledAdam(self.params, cfg, device, comm, capturable=self.graphed,
                                  grad_scaler=self.amp_dtype == torch.float16)
        self.minibatch_step = MinibatchStep(self._losses, self.adam, comm, graphed=self.graphed)
        # rl_games 2.0: advantages normalized by moving statistics instead of the batch's own
        self.advantage_stats = MovingAdvantageStats(cfg.adv_rms_momentum, device) \
            if cfg.normalize_advantage and cfg.normalize_rms_advantage else None

    # ----- the parts' public faces (rl_games' observers, the trainers, checkpoints) --------------
    @property
    def optimizer(self) -> torch.optim.Optimizer:
        """torch's Adam over :attr:`params`."""
        return self.adam.optimizer

    @property
    def lr(self) -> float:
        """The live learning rate."""
        return self.adam.lr

    @property
    def entropy_coef(self) -> float:
        """The live entropy coefficient."""
        return self.adam.entropy_coef

    @entropy_coef.setter
    def entropy_coef(self, value: float) -> None:
        self.adam.entropy_coef = value

    @property
    def schedule(self) -> object:
        """The learning-rate schedule (rlchain.algos.core.schedules)."""
        return self.adam.schedule

    @property
    def schedule_entropy(self) -> bool:
        """Whether the entropy coefficient follows the run's progress."""
        return self.adam.schedule_entropy

    @property
    def scaler(self) -> torch.amp.GradScaler | None:
        """float16 autocast's grad scaler, else None."""
        return self.adam.scaler

    # ----- the update -------------------------------------------------------------------------
    def update(self, storage: RolloutStorage, progress: float, obs_per_minibatch: bool = False) -> dict[str, float]:
        """Run ``mini_epochs`` passes of minibatch updates; return mean losses, kl and lr.

        Auxiliary losses of the network appear as ``losses/<name>``, averaged over the minibatches
        that returned them. ``obs_per_minibatch`` (``obs_normalizer_update: minibatch``): each minibatch
        of the first pass folds its observations into the input statistics just before its forward
        pass, as rl_games' training forward does (the caller has not folded the rollout in).
        """
        cfg = self.cfg
        advantages = self._batch_advantages(storage)
        sums = {"a_loss": 0.0, "c_loss": 0.0, "entropy": 0.0, "b_loss": 0.0, "kl": 0.0, "clip_frac": 0.0,
                "grad_norm": 0.0}
        count, aux_counts = 0, {}  # aux_counts: minibatches per losses/<name>
        reference = self._kl_reference(storage)
        for mini_epoch in range(cfg.mini_epochs):
            epoch_kl, epoch_n = 0.0, 0
            for batch in self._minibatches(storage, advantages):
                if obs_per_minibatch and mini_epoch == 0:
                    with torch.no_grad():
                        self.model.update_normalizers(obs=batch.obs)
                if self.should_stop is not None and self.should_stop():
                    raise UpdateInterrupted
                stats = self._step(batch, reference)
                for key, value in stats.items():
                    sums[key] = sums.get(key, 0.0) + value
                    if key.startswith("losses/"):  # auxiliary: averaged over the minibatches that had it
                        aux_counts[key] = aux_counts.get(key, 0) + 1
                count += 1
                epoch_kl += stats["kl"]
                epoch_n += 1
                if cfg.schedule_type == "legacy":
                    self.adam.follow_kl(stats["kl"])
            if cfg.schedule_type == "standard":
                self.adam.follow_kl(epoch_kl / max(epoch_n, 1))
        self.apply_progress(progress)
        out = {key: value / max(aux_counts.get(key, count), 1) for key, value in sums.items()}
        out["lr"] = self.lr
        out["entropy_coef"] = self.entropy_coef
        return out

    def _batch_advantages(self, storage: RolloutStorage) -> torch.Tensor:
        """The (T, N) advantages the update trains on: value heads summed (as in rl_games), then
        normalized over the whole batch once when ``normalize_advantage`` (``advantage_normalization:
        minibatch``: in each minibatch's loss instead)."""
        advantages = storage.advantages.sum(-1)
        if self.advantage_stats is not None:
            return self.advantage_stats.normalize(advantages)
        if self.cfg.normalize_advantage and self.cfg.advantage_normalization == "batch":
            advantages = normalize_advantages(advantages)
        return advantages

    def apply_progress(self, progress: float) -> None:
        """After an epoch's update: the schedules that follow the run's progress (linear or polynomial
        lr, ``schedule_entropy``) set the values the next epoch trains with."""
        self.adam.apply_progress(progress)

    def _kl_reference(self, storage: RolloutStorage) -> torch.Tensor | None:
        """With ``kl_reference: previous``, a (T * N, param_size) copy of the rollout's distribution
        parameters that :meth:`_step` measures the KL against and then overwrites with the policy it
        saw, so from the second pass on the KL is how far the policy moved since that sample's
        previous minibatch (rl_games' continuous agent). None: the KL is against the rollout policy."""
        mode = self.cfg.kl_reference
        if mode == "auto":
            mode = "previous" if self.model.dist.continuous else "rollout"
        if mode == "rollout":
            return None
        return storage.params.reshape(-1, storage.params.shape[-1]).clone()

    def _losses(self, batch: Batch, entropy_coef: torch.Tensor, reference: torch.Tensor) -> LossOutput:
        """One minibatch's forward pass and losses (:func:`rlchain.algos.ppo.loss.ppo_loss`) with this agent's
        model, config, surrogate and precision: the region ``compile_update`` compiles."""
        return ppo_loss(self.model, self.cfg, batch, entropy_coef, reference, self.surrogate, self.train_critic,
                        self.amp_dtype, self.device.type, autocast_cache=not self.graphed)

    def compile_losses(self) -> None:
        """``compile_update``: from now on :meth:`_losses` runs as one compiled region with static shapes."""
        self.minibatch_step.compile()

    def _step(self, batch: Batch, reference: torch.Tensor | None = None) -> dict[str, float]:
        """One minibatch update (what MinibatchStep runs): losses, backward, clip, optimizer step."""
        cfg = self.cfg
        previous = batch.params if reference is None else reference.index_select(0, batch.index)
        max_norm = cfg.grad_norm if cfg.truncate_grads else float("inf")
        return self.minibatch_step(batch, self.adam.entropy_coef_tensor(), previous, reference, max_norm)

    def surrogate(self, old_log_probs: torch.Tensor, log_probs: torch.Tensor,
                  advantages: torch.Tensor) -> torch.Tensor:
        """Per-sample policy loss (B,): PPO's clipped surrogate (IMPALA replaces it)."""
        return policy_loss(old_log_probs, log_probs, advantages, self.cfg.e_clip, self.cfg.use_smooth_clamp)

    def _minibatches(self, storage: RolloutStorage, advantages: torch.Tensor) -> Iterator[Batch]:
        """Flat minibatches, or whole sequences of seq_length steps for an RNN policy, in ``minibatch_order``."""
        cfg = self.cfg
        shuffle = shuffled_minibatches(cfg.minibatch_order, self.model.dist.continuous)
        if self.model.is_rnn:
            return storage.sequence_minibatches(cfg.minibatch_size, cfg.seq_length, advantages,
                                                use_resets=cfg.zero_rnn_on_done, shuffle=shuffle)
        return storage.minibatches(cfg.minibatch_size, advantages, shuffle=shuffle)

    # ----- live values and checkpoints ----------------------------------------------------------
    def scale_lr(self, factor: float) -> None:
        """Multiply the learning rate (divergence rollback)."""
        self.adam.scale_lr(factor)

    def live_hyperparams(self) -> dict[str, float]:
        """The values the agent's schedules change during training (what get_params must report)."""
        return self.adam.live_hyperparams()

    def set_hyperparam(self, name: str, value: float) -> bool:
        """Change a live value the agent owns (True), else False: the trainer's config holds it. A new
        ``kl_threshold`` reaches the adaptive schedule too, and returns False so the config keeps it."""
        return self.adam.set_hyperparam(name, value)

    def config_changed(self) -> None:
        """A value of ``cfg`` changed (population-based training): a captured step holds the old one as a
        constant, so it is recorded again."""
        self.minibatch_step.reset()

    def state_dict(self) -> dict:
        """Optimizer state, live lr and entropy coefficient (:meth:`ScheduledAdam.state_dict`), and the moving
        advantage statistics under rl_games' ``advantage_mean_std`` when ``normalize_rms_advantage``."""
        state = self.adam.state_dict()
        if self.advantage_stats is not None:
            state["advantage_mean_std"] = self.advantage_stats.state_dict()
        return state

    def load_state_dict(self, state: dict) -> None:
        """Restore :meth:`state_dict`; new optimizer state tensors: a captured step is recorded again."""
        state = dict(state)
        advantage_stats = state.pop("advantage_mean_std", None)
        if self.advantage_stats is not None and advantage_stats is not None:
            self.advantage_stats.load_state_dict(advantage_stats)
        self.adam.load_state_dict(state)
        self.minibatch_step.reset()


def shuffled_minibatches(order: str, continuous: bool) -> bool:
    """``minibatch_order`` resolved: True for a new permutation every mini-epoch, False for rl_games'
    fixed env-major blocks (``auto``: fixed for continuous actions, shuffled otherwise)."""
    return order == "shuffle" or (order == "auto" and not continuous)

