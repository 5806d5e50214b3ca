"""Training the asymmetric critic (``central_value_config``) on a filled rollout, apart from the actor."""

from __future__ import annotations

from collections.abc import Callable

import torch

from rlchain.algos.base.safety import UpdateInterrupted
from rlchain.algos.core.losses import value_loss
from rlchain.algos.core.schedules import set_lr
from rlchain.algos.core.storage import RolloutStorage
from rlchain.config.ppo import CentralValueConfig
from rlchain.errors import DivergenceError
from rlchain.models.central_value import CentralValue
from rlchain.parallel.communicator import SINGLE, Communicator


class CentralValueAgent:
    """Its own Adam optimizer, minibatches and mini-epochs; clipped value loss as the PPO critic's."""

    def __init__(self, model: CentralValue, cfg: CentralValueConfig, device: torch.device,
                 comm: Communicator = SINGLE, should_stop: Callable[[], bool] | None = None) -> None:
        self.model, self.cfg, self.device, self.comm = model, cfg, device, comm
        self.lr = cfg.learning_rate
        self.should_stop = should_stop  # checked between minibatches (a stop signal)
        self.params = [p for p in model.parameters() if p.requires_grad]
        self.optimizer = torch.optim.Adam(self.params, lr=self.lr, eps=1e-8, weight_decay=cfg.weight_decay)

    def update(self, storage: RolloutStorage, progress: float, state_offset: int = 0, seq_length: int = 1,
               use_resets: bool = True, shuffle: bool = True) -> dict[str, float]:
        """``mini_epochs`` passes over the rollout's (obs, old values, returns); -> mean loss and lr.

        A recurrent critic trains on whole sequences of ``seq_length`` steps; its RNN states are the
        storage's states from index ``state_offset`` on (the actor's come first). ``shuffle``: the
        actor's ``minibatch_order`` (shuffle, or rl_games' fixed env-major blocks).
        """
        cfg, model = self.cfg, self.model
        if cfg.lr_schedule == "linear":
            self._set_lr(cfg.learning_rate * max(0.0, 1.0 - progress))
        zeros = torch.zeros(storage.horizon, storage.num_envs, device=storage.obs.device)
        total, count = torch.zeros((), device=storage.obs.device), 0
        model.train()
        for _ in range(cfg.mini_epochs):
            if model.is_rnn:
                batches = storage.sequence_minibatches(cfg.minibatch_size, seq_length, zeros, use_resets, shuffle)
            else:
                batches = storage.minibatches(cfg.minibatch_size, zeros, shuffle)
            for batch in batches:
                if self.should_stop is not None and self.should_stop():
                    raise UpdateInterrupted
                states = batch.states[state_offset:] if batch.states else ()
                predicted, _ = model(batch.obs, states, batch.resets, batch.seq_length)
                loss = value_loss(predicted, model.norm_value(batch.values), model.norm_value(batch.returns),
                                  cfg.e_clip, cfg.clip_value).mean()
                self.optimizer.zero_grad(set_to_none=True)
                loss.backward()
                if self.comm.active:  # multi_gpu: every rank steps with the gradients averaged over ranks
                    self.comm.average_gradients(self.params)
                if cfg.truncate_grads:
                    torch.nn.utils.clip_grad_norm_(self.params, cfg.grad_norm)
                self.optimizer.step()
                total += loss.detach()
                count += 1
        mean = float(total) / max(count, 1)
        if mean != mean or mean in (float("inf"), float("-inf")):
            raise DivergenceError("central value loss is not finite")
        return {"cval_loss": mean, "cval_lr": self.lr}

    def _set_lr(self, lr: float) -> None:
        self.lr = lr
        set_lr(self.optimizer, lr)

    def state_dict(self) -> dict:
        return {"optimizer": self.optimizer.state_dict(), "lr": self.lr}

    def load_state_dict(self, state: dict) -> None:
        self.optimizer.load_state_dict(state["optimizer"])
        self._set_lr(float(state["lr"]))
