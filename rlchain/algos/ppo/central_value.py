"""Training the asymmetric critic (``central_value_config``) on a filled rollout, apart from the actor."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import torch

from rlchain.algos.base.safety import UpdateInterrupted
from rlchain.algos.core.adam_agent import AdamAgent, loss_stats
from rlchain.algos.core.losses import value_loss
from rlchain.algos.core.storage import RolloutStorage
from rlchain.config.ppo import CentralValueConfig
from rlchain.models.central_value import CentralValue
from rlchain.parallel.communicator import SINGLE, Communicator


class CentralValueAgent(AdamAgent):
    """Its own Adam optimizer (and linear lr), minibatches and mini-epochs; clipped value loss as the PPO
    critic's."""

    def __init__(self, model: CentralValue, cfg: CentralValueConfig, comm: Communicator = SINGLE,
                 should_stop: Callable[[], bool] | None = None) -> None:
        super().__init__(model, cfg.learning_rate, cfg.weight_decay, comm, cfg.lr_schedule)
        self.model, self.cfg = model, cfg
        self.should_stop = should_stop  # checked between minibatches (a stop signal)

    def update(self, storage: RolloutStorage, progress: float, state_offset: int = 0, seq_length: int = 1,
               use_resets: bool = True, shuffle: bool = True) -> dict[str, float]:
        """``mini_epochs`` passes over the rollout's (obs, old values, returns); -> mean loss and lr.

        A recurrent critic trains on whole sequences of ``seq_length`` steps; its RNN states are the
        storage's states from index ``state_offset`` on (the actor's come first). ``shuffle``: the
        actor's ``minibatch_order`` (shuffle, or rl_games' fixed env-major blocks).
        """
        cfg, model = self.cfg, self.model
        self.apply_progress(progress)
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
                self.step(loss, cfg.grad_norm if cfg.truncate_grads else None, partial(loss_stats, loss),
                          "the central value update")
                total += loss.detach()
                count += 1
        return {"cval_loss": float(total) / max(count, 1), "cval_lr": self.lr}

    def state_dict(self) -> dict:
        return {**super().state_dict(), "lr": self.lr}

    def load_state_dict(self, state: dict) -> None:
        super().load_state_dict(state)
        self.set_lr(float(state["lr"]))
