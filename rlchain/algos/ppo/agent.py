"""The on-policy PPO agent (``a2c_continuous`` and ``a2c_discrete`` are presets of it).

It owns the optimizer and learning-rate schedule and turns a filled rollout into parameter
updates. There is no action-space branch here: the model's distribution handles that.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import nullcontext

import torch

from rlchain.algos.base.safety import UpdateInterrupted
from rlchain.algos.core.losses import aux_loss_terms, normalize_advantages, policy_loss, value_loss
from rlchain.algos.core.precision import autocast_dtype
from rlchain.algos.core.schedules import (
    PROGRESS_SCHEDULES,
    AdaptiveKLSchedule,
    make_schedule,
    scheduled_entropy_coef,
    set_lr,
)
from rlchain.algos.core.storage import Batch, RolloutStorage
from rlchain.algos.ppo.graph_step import GraphedStep, zero_non_finite_
from rlchain.config.schema import PPOConfig
from rlchain.errors import DivergenceError, first_non_finite
from rlchain.log import get_logger
from rlchain.models.actor_critic import ActorCritic
from rlchain.parallel.communicator import SINGLE, Communicator

_log = get_logger(__name__)


class PPOAgent:
    """Clipped-surrogate PPO with value clipping, entropy and bounds losses, adaptive/linear/polynomial lr.

    ``lr`` and ``entropy_coef`` are the live values (they change with the schedules, population-based
    training and divergence rollbacks) and travel in :meth:`state_dict`, so a resumed run goes on
    with the values the interrupted one had; ``cfg`` keeps the configured start values.

    A network with ``get_aux_loss()`` (rl_games' contract) has its auxiliary losses added to the
    loss after each forward pass; they come back from :meth:`update` as ``losses/<name>``.
    """

    def __init__(self, model: ActorCritic, cfg: PPOConfig, device: torch.device,
                 comm: Communicator = SINGLE, cuda_graph: bool = False) -> None:
        self.model = model
        self.comm = comm  # multi_gpu: gradients and the KL behind the adaptive lr are averaged over ranks
        self.cfg = cfg
        self.device = device
        self.lr = cfg.learning_rate
        self.should_stop: Callable[[], bool] | None = None  # checked between minibatches (a stop signal)
        self.params = [p for p in model.parameters() if p.requires_grad]
        # cuda_graph: Adam reads its lr from a device tensor the captured step writes (lr_live, or 0 for
        # a non-finite step); every other path keeps a float lr
        self.graphed = cuda_graph  # resolved by the trainer (rlchain.algos.ppo.graph_step.resolve_cuda_graph)
        self._lr_live = torch.tensor(float(self.lr), device=device) if self.graphed else None
        self._lr_step = self._lr_live.clone() if self.graphed else None
        self.optimizer = torch.optim.Adam(self.params, lr=self._lr_step if self.graphed else self.lr, eps=1e-8,
                                          weight_decay=cfg.weight_decay, **_fast_adam_kwargs(device),
                                          **({"capturable": True} if self.graphed else {}))
        self.schedule = make_schedule(cfg.lr_schedule, cfg.learning_rate, cfg.kl_threshold,
                                      cfg.min_lr, cfg.max_lr, cfg.decay_power, cfg.lr_multiplier)
        self.entropy_coef = cfg.entropy_coef
        # schedule_entropy applies with the linear lr only, as in rl_games (config load warns otherwise)
        self.schedule_entropy = cfg.schedule_entropy and cfg.lr_schedule == "linear"
        self.train_critic = True  # False with a central value network (it trains the values itself)
        model.bptt_length = cfg.bptt_length
        # mixed_precision: bf16 autocast, no scaler (rl_games 2.0; on a CPU with native bf16 too); fp16
        # autocast with a GradScaler (1.6, CUDA)
        self.amp_dtype = autocast_dtype(cfg.mixed_precision, device)
        self.amp = self.amp_dtype is not None
        scaled = self.amp_dtype == torch.float16
        self.scaler = torch.amp.GradScaler("cuda", enabled=True) if scaled else None
        self._coef_value, self._coef = None, None
        self._losses_fn = self._losses  # compile_losses() swaps in the compiled region
        self._compile_pending = False
        self._graph = GraphedStep(self.sync_free_step, self._grads_to_none) if self.graphed else None
        self._aux_names: tuple[str, ...] = ()

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
                    self._set_lr(self.schedule.update(self.lr, kl=self._rank_mean(stats["kl"])))
            if cfg.schedule_type == "standard":
                self._set_lr(self.schedule.update(self.lr, kl=self._rank_mean(epoch_kl / max(epoch_n, 1))))
        self.apply_progress(progress)
        out = {key: value / max(aux_counts.get(key, count), 1) for key, value in sums.items()}
        out["lr"] = self.lr
        out["entropy_coef"] = self.entropy_coef
        return out

    def _batch_advantages(self, storage: RolloutStorage) -> torch.Tensor:
        """The (T, N) advantages the update trains on: value heads summed (as in rl_games), then
        normalized over the whole batch once when ``normalize_advantage``."""
        advantages = storage.advantages.sum(-1)
        if self.cfg.normalize_advantage:
            advantages = normalize_advantages(advantages)
        return advantages

    def _rank_mean(self, kl: float) -> float:
        """The KL the adaptive lr follows: averaged over ranks, so every rank sets the same lr."""
        if self.comm.active and isinstance(self.schedule, AdaptiveKLSchedule):
            return self.comm.mean(kl)
        return kl

    def apply_progress(self, progress: float) -> None:
        """After an epoch's update: the schedules that follow the run's progress (linear or polynomial
        lr, ``schedule_entropy``) set the values the next epoch trains with."""
        if isinstance(self.schedule, PROGRESS_SCHEDULES):
            self._set_lr(self.schedule.update(self.lr, progress=progress))
        if self.schedule_entropy:
            self.entropy_coef = scheduled_entropy_coef(self.cfg.entropy_coef, progress)

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

    def _losses(self, batch: Batch, entropy_coef: torch.Tensor, reference: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor, dict[str, torch.Tensor], torch.Tensor]:
        """One minibatch's forward pass and losses: (loss, detached stats (a_loss, c_loss, entropy, b_loss,
        clip_frac, kl), the network's auxiliary losses, the policy's params, detached). ``reference``
        (B, param_size) is the distribution the KL is measured against.

        No side effects and no host syncs: this is the region ``compile_update`` compiles (with the
        backward pass AOTAutograd derives from it). ``entropy_coef`` is a 0-d tensor so a scheduled
        coefficient does not recompile it. Under ``mixed_precision`` the network's forward pass runs in
        autocast and its outputs are cast back to float32, so the log-probs, ratios, KL and losses are
        computed in float32 against the rollout's float32 log-probs."""
        cfg, model, dist = self.cfg, self.model, self.model.dist
        autocast = (torch.autocast(self.device.type, dtype=self.amp_dtype, cache_enabled=not self.graphed)
                    if self.amp else nullcontext())
        with autocast:
            params, values, _ = model.evaluate(batch.obs, batch.states, batch.resets, batch.seq_length,
                                               batch.action_masks)
            aux = aux_loss_terms(model.aux_losses())  # {} for a network without get_aux_loss()
        if self.amp:
            params, values = params.float(), values.float()
            aux = {name: value.float() for name, value in aux.items()}
        log_probs, entropy = dist.log_prob_and_entropy(params, batch.actions)
        entropy = entropy.mean()
        a_loss = self.surrogate(batch.log_probs, log_probs, batch.advantages).mean()
        if self.train_critic:
            c_loss = value_loss(values, model.norm_value(batch.values), model.norm_value(batch.returns),
                                cfg.e_clip, cfg.clip_value).mean()
        else:
            c_loss = torch.zeros((), device=values.device)
        loss = a_loss + 0.5 * cfg.critic_coef * c_loss - entropy_coef * entropy
        b_loss = torch.zeros((), device=params.device)
        if cfg.bounds_loss_coef:
            b_loss = dist.bounds_loss(params, cfg.bound_loss_type).mean()
            loss = loss + cfg.bounds_loss_coef * b_loss
        for aux_loss in aux.values():
            loss = loss + aux_loss
        with torch.no_grad():
            current = params.detach().float()
            kl = dist.kl(reference, current).mean()
            ratio = torch.exp(log_probs.detach() - batch.log_probs)
            clip_frac = ((ratio - 1.0).abs() > cfg.e_clip).float().mean()
        stats = torch.stack([a_loss.detach().float(), c_loss.detach().float(), entropy.detach().float(),
                             b_loss.detach().float(), clip_frac, kl.float()])
        return loss, stats, aux, current

    def compile_losses(self) -> None:
        """``compile_update``: from now on :meth:`_losses` runs as one compiled region with static
        shapes (the minibatch size divides the batch, so every minibatch has the same shape). The
        compile happens on the first minibatch; its seconds are logged."""
        self._losses_fn = torch.compile(self._losses, dynamic=False)
        self._compile_pending = True

    def _compiled_losses(self, batch: Batch, coef: torch.Tensor, reference: torch.Tensor) -> tuple:
        """:meth:`_losses` through ``_losses_fn``, logging the seconds the first (compiling) call took."""
        if not self._compile_pending:
            return self._losses_fn(batch, coef, reference)
        start = time.perf_counter()
        out = self._losses_fn(batch, coef, reference)
        self._compile_pending = False
        _log.info(f"compile_update: compiled the PPO minibatch step in {time.perf_counter() - start:.1f} s")
        return out

    def _step(self, batch: Batch, reference: torch.Tensor | None = None) -> dict[str, float]:
        """One minibatch update: losses (compiled with ``compile_update``), backward, clip, optimizer step."""
        coef = self._entropy_coef_tensor()
        previous = batch.params if reference is None else reference.index_select(0, batch.index)
        if self._graph is not None:
            return self._graph_step(batch, coef, previous, reference)
        loss, stats_t, aux, current = self._compiled_losses(batch, coef, previous)
        if reference is not None:  # the next pass measures the KL against the policy this one saw
            reference.index_copy_(0, batch.index, current)
        self.optimizer.zero_grad(set_to_none=True)
        (self.scaler.scale(loss) if self.scaler is not None else loss).backward()
        if self.comm.active:  # before unscaling and clipping, so every rank sees the same grads
            self.comm.average_gradients(self.params)
        if self.scaler is not None:
            self.scaler.unscale_(self.optimizer)
        stats = _named_stats(self._stats_vector(loss, stats_t, aux, self._clip_grads()).tolist(), aux)
        bad = first_non_finite(stats)
        if bad is not None and self.scaler is None:  # with AMP the scaler skips inf steps itself
            raise DivergenceError(f"{bad} in the PPO update")
        if self.scaler is not None:
            self.scaler.step(self.optimizer)
            self.scaler.update()
        else:
            self.optimizer.step()
        del stats["loss"]
        return stats

    def sync_free_step(self, batch: Batch, coef: torch.Tensor, previous: torch.Tensor
                       ) -> tuple[torch.Tensor, torch.Tensor]:
        """The minibatch step ``cuda_graph`` captures: losses, backward, clip, Adam, with no host sync.

        Returns (the statistics of :attr:`STEP_STATS` then the auxiliary losses, as one float32 vector;
        the policy's params). The gradients must be None or zero on entry (the eager warm-up sets them to
        None; in the graph backward writes the graph's own). A non-finite statistic zeroes the gradients
        and this step's lr, so the parameters stay as they were and the caller raises on the statistics.
        """
        loss, stats_t, aux, current = self._compiled_losses(batch, coef, previous)
        loss.backward()
        values = self._stats_vector(loss, stats_t, aux, self._clip_grads())
        finite = torch.isfinite(values).all()
        zero_non_finite_(finite, self.params)
        self._lr_step.copy_(self._lr_live * finite)
        self.optimizer.step()
        self._aux_names = tuple(aux)
        return values, current

    def _clip_grads(self) -> torch.Tensor:
        """Clip the gradients to ``grad_norm`` when ``truncate_grads``; their total norm before clipping."""
        max_norm = self.cfg.grad_norm if self.cfg.truncate_grads else float("inf")
        return torch.nn.utils.clip_grad_norm_(self.params, max_norm, foreach=True)

    @staticmethod
    def _stats_vector(loss: torch.Tensor, stats_t: torch.Tensor, aux: dict[str, torch.Tensor],
                      grad_norm: torch.Tensor) -> torch.Tensor:
        """A step's statistics as one float32 vector in :data:`STEP_STATS` order, the auxiliary losses after."""
        return torch.cat([stats_t, torch.stack([loss.detach().float(), grad_norm.detach().float(),
                                                *(value.detach().float() for value in aux.values())])])

    def _grads_to_none(self) -> None:
        self.optimizer.zero_grad(set_to_none=True)

    def _graph_step(self, batch: Batch, coef: torch.Tensor, previous: torch.Tensor,
                    reference: torch.Tensor | None) -> dict[str, float]:
        """:meth:`_step` through the captured graph: the same statistics, one host sync to read them."""
        values, current = self._graph(batch, coef, previous)
        if reference is not None:
            reference.index_copy_(0, batch.index, current)
        stats = _named_stats(values.tolist(), self._aux_names)
        bad = first_non_finite(stats)
        if bad is not None:  # the step left the parameters as they were
            raise DivergenceError(f"{bad} in the PPO update")
        del stats["loss"]
        return stats

    def _entropy_coef_tensor(self) -> torch.Tensor:
        """The live entropy coefficient as a 0-d tensor on the device, rebuilt only when it changes."""
        if self._coef_value != self.entropy_coef:
            self._coef_value = self.entropy_coef
            self._coef = torch.tensor(float(self.entropy_coef), device=self.device)
        return self._coef

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

    def scale_lr(self, factor: float) -> None:
        """Multiply the learning rate (divergence rollback)."""
        self._set_lr(self.lr * factor)

    def live_hyperparams(self) -> dict[str, float]:
        """The values the agent's schedules change during training (what get_params must report)."""
        return {"learning_rate": self.lr, "entropy_coef": self.entropy_coef}

    def set_hyperparam(self, name: str, value: float) -> bool:
        """Change a live value the agent owns (True), else False: the trainer's config holds it. A new
        ``kl_threshold`` reaches the adaptive schedule too, and returns False so the config keeps it."""
        if name == "learning_rate":
            self._set_lr(float(value))
            return True
        if name == "entropy_coef":  # the live value; schedule_entropy sets it again after the epoch
            self.entropy_coef = float(value)
            return True
        if name == "kl_threshold" and hasattr(self.schedule, "kl_threshold"):
            self.schedule.kl_threshold = float(value)
        return False

    def config_changed(self) -> None:
        """A value of ``cfg`` changed (population-based training): a captured step holds the old one as a
        constant, so it is recorded again."""
        if self._graph is not None:
            self._graph.reset()

    def _set_lr(self, lr: float) -> None:
        self.lr = lr
        if self.graphed:  # Adam reads it from the device (the captured step copies it into its group lr)
            self._lr_live.fill_(float(lr))
        else:
            set_lr(self.optimizer, lr)

    def state_dict(self) -> dict:
        """Optimizer state, live lr and entropy coefficient. A ``cuda_graph`` run saves its optimizer as an
        eager one would (float lr, not capturable), so any run can load its checkpoints."""
        optimizer = self.optimizer.state_dict()
        if self.graphed:
            for group in optimizer["param_groups"]:
                group["lr"], group["capturable"] = float(self.lr), False
        state = {"optimizer": optimizer, "lr": self.lr, "entropy_coef": self.entropy_coef}
        if self.scaler is not None:
            state["scaler"] = self.scaler.state_dict()
        return state

    def load_state_dict(self, state: dict) -> None:
        self.optimizer.load_state_dict(state["optimizer"])
        if self.graphed:  # new optimizer state tensors: the captured step is recorded again
            for group in self.optimizer.param_groups:
                group["lr"], group["capturable"] = self._lr_step, True
            self._graph.reset()
        self._set_lr(float(state["lr"]))
        self.entropy_coef = float(state.get("entropy_coef", self.cfg.entropy_coef))  # older checkpoints: none
        if self.scaler is not None and "scaler" in state:
            self.scaler.load_state_dict(state["scaler"])


STEP_STATS = ("a_loss", "c_loss", "entropy", "b_loss", "clip_frac", "kl", "loss", "grad_norm")
"""The statistics of a minibatch step, in the order of its statistics vector (auxiliary losses follow)."""


def _named_stats(values: list[float], aux_names: Iterable[str]) -> dict[str, float]:
    """A step's statistics vector (read back) by name: :data:`STEP_STATS`, then ``losses/<name>``."""
    return dict(zip((*STEP_STATS, *(f"losses/{name}" for name in aux_names)), values))


def _fast_adam_kwargs(device: torch.device) -> dict:
    """The fused Adam kernel: one call per step instead of a Python loop over parameters."""
    return {"fused": True} if device.type in ("cpu", "cuda") else {}


def shuffled_minibatches(order: str, continuous: bool) -> bool:
    """``minibatch_order`` resolved: True for a new permutation every mini-epoch, False for rl_games'
    fixed env-major blocks (``auto``: fixed for continuous actions, shuffled otherwise)."""
    return order == "shuffle" or (order == "auto" and not continuous)

