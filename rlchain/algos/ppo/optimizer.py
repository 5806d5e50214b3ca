"""PPO's optimizer and schedules: Adam with the live learning rate and its schedule, the entropy coefficient
and ``schedule_entropy``, and the float16 grad scaler; what a checkpoint keeps of them."""

from __future__ import annotations

import torch

from rlchain.algos.core.optimizer_step import clear_grads
from rlchain.algos.core.schedules import (
    PROGRESS_SCHEDULES,
    AdaptiveKLSchedule,
    make_schedule,
    scheduled_entropy_coef,
    set_lr,
)
from rlchain.config.ppo import PPOConfig
from rlchain.parallel.communicator import SINGLE, Communicator


class ScheduledAdam:
    """Adam over ``params`` and the values PPO's schedules change during a run.

    ``lr`` and ``entropy_coef`` are the live values (the schedules, population-based training and divergence
    rollbacks change them) and travel in :meth:`state_dict`, so a resumed run goes on with the values the
    interrupted one had. The configured start values are read once, here: a run changes the live values,
    never ``cfg``'s ``learning_rate`` or ``entropy_coef``.

    ``capturable`` (``cuda_graph``): Adam reads its lr from a device tensor, ``lr_step``, which the captured
    step writes (``lr_live``, or 0 for a non-finite step); otherwise the lr is a float. ``grad_scaler``:
    float16 autocast's GradScaler (CUDA) scales the loss and skips steps with inf gradients.
    """

    def __init__(self, params: list[torch.nn.Parameter], cfg: PPOConfig, device: torch.device,
                 comm: Communicator = SINGLE, capturable: bool = False, grad_scaler: bool = False) -> None:
        self.params = params
        self.comm = comm  # multi_gpu: the KL behind the adaptive lr is averaged over ranks
        self.capturable = capturable
        self.lr = cfg.learning_rate
        self.lr_live = torch.tensor(float(self.lr), device=device) if capturable else None
        self.lr_step = self.lr_live.clone() if capturable else None
        self.optimizer = torch.optim.Adam(params, lr=self.lr_step if capturable else self.lr, eps=1e-8,
                                          weight_decay=cfg.weight_decay, **fast_adam_kwargs(device),
                                          **({"capturable": True} if capturable else {}))
        self.schedule = make_schedule(cfg.lr_schedule, cfg.learning_rate, cfg.kl_threshold,
                                      cfg.min_lr, cfg.max_lr, cfg.decay_power, cfg.lr_multiplier)
        self.entropy_start = cfg.entropy_coef
        self.entropy_coef = cfg.entropy_coef
        # schedule_entropy applies with the linear lr only, as in rl_games (config load warns otherwise)
        self.schedule_entropy = cfg.schedule_entropy and cfg.lr_schedule == "linear"
        self.scaler = torch.amp.GradScaler("cuda", enabled=True) if grad_scaler else None
        self._device = device
        self._coef_value: float | None = None
        self._coef: torch.Tensor | None = None

    # ----- the live values ----------------------------------------------------------------------
    def set_lr(self, lr: float) -> None:
        """Train with ``lr`` from the next step on."""
        self.lr = lr
        if self.capturable:  # Adam reads it from the device (the captured step copies it into its group lr)
            self.lr_live.fill_(float(lr))
        else:
            set_lr(self.optimizer, lr)

    def scale_lr(self, factor: float) -> None:
        """Multiply the learning rate (divergence rollback)."""
        self.set_lr(self.lr * factor)

    def follow_kl(self, kl: float) -> None:
        """The adaptive schedule's step after a minibatch (``schedule_type: legacy``) or a pass (``standard``):
        ``kl`` averaged over ranks, so every rank sets the same lr. Other schedules keep the lr here."""
        if self.comm.active and isinstance(self.schedule, AdaptiveKLSchedule):
            kl = self.comm.mean(kl)
        self.set_lr(self.schedule.update(self.lr, kl=kl))

    def apply_progress(self, progress: float) -> None:
        """After an epoch's update: the schedules that follow the run's progress (linear or polynomial
        lr, ``schedule_entropy``) set the values the next epoch trains with."""
        if isinstance(self.schedule, PROGRESS_SCHEDULES):
            self.set_lr(self.schedule.update(self.lr, progress=progress))
        if self.schedule_entropy:
            self.entropy_coef = scheduled_entropy_coef(self.entropy_start, progress)

    def entropy_coef_tensor(self) -> torch.Tensor:
        """The live entropy coefficient as a 0-d tensor on the device, rebuilt only when it changes."""
        if self._coef_value != self.entropy_coef:
            self._coef_value = self.entropy_coef
            self._coef = torch.tensor(float(self.entropy_coef), device=self._device)
        return self._coef

    def live_hyperparams(self) -> dict[str, float]:
        """The values the schedules change during training (what get_params must report)."""
        return {"learning_rate": self.lr, "entropy_coef": self.entropy_coef}

    def set_hyperparam(self, name: str, value: float) -> bool:
        """Change a live value held here (True), else False: the run's config holds it. A new
        ``kl_threshold`` reaches the adaptive schedule too, and returns False so the config keeps it."""
        if name == "learning_rate":
            self.set_lr(float(value))
            return True
        if name == "entropy_coef":  # the live value; schedule_entropy sets it again after the epoch
            self.entropy_coef = float(value)
            return True
        if name == "kl_threshold" and hasattr(self.schedule, "kl_threshold"):
            self.schedule.kl_threshold = float(value)
        return False

    def clear_grads(self) -> None:
        """Gradients to None: the next backward pass allocates them."""
        clear_grads(self.optimizer)

    # ----- checkpoints --------------------------------------------------------------------------
    def state_dict(self) -> dict:
        """Optimizer state, live lr and entropy coefficient (and the grad scaler's). A capturable optimizer is
        saved as an eager one would be (float lr, not capturable), so any run can load its checkpoints."""
        optimizer = self.optimizer.state_dict()
        if self.capturable:
            for group in optimizer["param_groups"]:
                group["lr"], group["capturable"] = float(self.lr), False
        state = {"optimizer": optimizer, "lr": self.lr, "entropy_coef": self.entropy_coef}
        if self.scaler is not None:
            state["scaler"] = self.scaler.state_dict()
        return state

    def load_state_dict(self, state: dict) -> None:
        """Restore :meth:`state_dict` (a checkpoint without ``entropy_coef`` keeps the configured one)."""
        self.optimizer.load_state_dict(state["optimizer"])
        if self.capturable:
            for group in self.optimizer.param_groups:
                group["lr"], group["capturable"] = self.lr_step, True
        self.set_lr(float(state["lr"]))
        self.entropy_coef = float(state.get("entropy_coef", self.entropy_start))
        if self.scaler is not None and "scaler" in state:
            self.scaler.load_state_dict(state["scaler"])


def fast_adam_kwargs(device: torch.device) -> dict:
    """The fused Adam kernel: one call per step instead of a Python loop over parameters."""
    return {"fused": True} if device.type in ("cpu", "cuda") else {}
