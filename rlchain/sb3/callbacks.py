"""Stable-Baselines3's callbacks on rlchain's loop: ``model.learn(n, callback=EvalCallback(...))`` as written.

Any object with SB3's callback protocol (``BaseCallback`` subclasses, ``CallbackList``, ``EvalCallback``,
``CheckpointCallback``, ``StopTrainingOn...``, ``ProgressBarCallback``; recognised by its methods, so SB3 is
never imported here) is driven by :class:`SB3Callbacks`, an rlchain callback, the way SB3's learn loop drives it:

- ``init_callback(model)`` and ``on_training_start(locals, globals)`` when the run starts (``self.model`` is the
  rlchain model: ``predict``, ``save``, ``get_env``, ``logger``, ``num_timesteps``, ``get_vec_normalize_env``);
- ``on_rollout_start()`` before an epoch's first env step, ``on_rollout_end()`` after its last;
- ``update_locals`` and ``on_step()`` after every vector step, with ``model.num_timesteps`` already counting it and
  ``self.locals`` holding ``new_obs``, ``rewards``, ``dones`` and ``infos`` (SB3's list of per-env dicts, with
  ``terminal_observation``, ``TimeLimit.truncated`` and a Monitor-style ``episode`` for finished envs). ``False``
  stops the run at once, as SB3 does: the rollout in progress is not trained on (``on_rollout_end`` is not called),
  and the last whole epoch's checkpoint is written;
- ``on_training_end()`` when it ends.

``self.logger.record(key, value)`` / ``dump(step)`` go to rlchain's log writers (TensorBoard, wandb, ...) through
:class:`~rlchain.sb3.logger.SB3Logger`, dumped at SB3's log interval (``learn``'s ``log_interval``: PPO every
that many iterations, default 1; SAC and DQN every that many finished episodes, default 4). A run without SB3
callbacks gets no :class:`SB3Callbacks` and pays nothing per step.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from rlchain.errors import CallbackError
from rlchain.sb3.logger import SB3Logger  # noqa: F401  (importable from here too)
from rlchain.training.events import Callback

STOP_REASON = "a Stable-Baselines3 callback returned False"
LOG_INTERVAL = {"ppo": 1, "sac": 4, "dqn": 4}
"""SB3's default ``log_interval`` of ``learn``: iterations (on-policy) or episodes (off-policy) between dumps."""


def is_sb3_callback(obj: Any) -> bool:
    """Whether ``obj`` has SB3's callback protocol (``init_callback``, ``on_step``, ``update_locals``)."""
    return all(callable(getattr(obj, name, None)) for name in ("init_callback", "on_step", "update_locals"))


class _Episodes:
    """Per-env running return and length, for the Monitor-style ``info['episode']`` of finished envs."""

    def __init__(self, num_envs: int) -> None:
        self.returns = np.zeros(num_envs, np.float64)
        self.lengths = np.zeros(num_envs, np.int64)
        self.start = time.time()

    def step(self, rewards: np.ndarray, dones: np.ndarray) -> dict[int, dict[str, float]]:
        self.returns += rewards
        self.lengths += 1
        ended = {int(i): {"r": float(self.returns[i]), "l": int(self.lengths[i]),
                          "t": round(time.time() - self.start, 6)} for i in np.flatnonzero(dones)}
        self.returns[dones] = 0.0
        self.lengths[dones] = 0
        return ended


def _numpy(x: Any) -> Any:
    return x.detach().cpu().numpy() if hasattr(x, "detach") else (None if x is None else np.asarray(x))


class SB3Callbacks(Callback):
    """Drives SB3-protocol ``callbacks`` for ``model`` (see the module docstring); ``learn_locals`` are what
    SB3's ``learn`` has in its locals (``total_timesteps``, ``callback``, ``log_interval``, ...)."""

    def __init__(self, model: Any, callbacks: list[Any], learn_locals: dict[str, Any]) -> None:
        self.model = model
        self.callbacks = list(callbacks)
        self.learn_locals = dict(learn_locals)
        self._in_rollout = False
        self._stopped = False
        self._episodes: _Episodes | None = None
        given = self.learn_locals.get("log_interval")
        self.log_interval = int(given) if given is not None else LOG_INTERVAL[getattr(model, "algo", "ppo")]
        self._iterations = self._episode_count = 0

    def on_train_start(self, ctx: Any) -> None:
        self.model.logger.writer = ctx.writer
        self.model.logger.dir = ctx.state.experiment_dir or None
        for cb in self.callbacks:
            cb.init_callback(self.model)
        for cb in self.callbacks:
            cb.on_training_start(dict(self.learn_locals), {})

    def on_env_step(self, ctx: Any, result: Any, done_indices: Any, rows: slice) -> None:
        if self._stopped:
            return
        if not self._in_rollout:
            self._in_rollout = True
            for cb in self.callbacks:
                cb.on_rollout_start()
        rewards = _numpy(result.reward).reshape(-1)
        terminated, truncated = _numpy(result.terminated).reshape(-1), _numpy(result.truncated).reshape(-1)
        dones = terminated | truncated
        self.model.num_timesteps += len(rewards)
        infos = self._infos(result, rewards, dones, truncated)
        step_locals = {"new_obs": _numpy(result.obs), "rewards": rewards, "dones": dones, "infos": infos,
                       "self": self.model, **self.learn_locals}
        for cb in self.callbacks:
            cb.update_locals(step_locals)
            try:
                keep_going = cb.on_step()
            except Exception as exc:  # named as the user's class, not this adapter
                raise CallbackError(type(cb).__name__, "_on_step", exc) from exc
            if keep_going is False:
                self._stopped = True
                ctx.request_stop(STOP_REASON)
                return
        if getattr(self.model, "algo", "ppo") != "ppo":  # off-policy: SB3 dumps every log_interval episodes
            for _ in range(int(dones.sum())):
                self._episode_count += 1
                if self.log_interval > 0 and self._episode_count % self.log_interval == 0:
                    self.model.logger.dump(self.model.num_timesteps)

    def _infos(self, result: Any, rewards: np.ndarray, dones: np.ndarray, truncated: np.ndarray) -> list[dict]:
        """SB3's per-env info dicts: the SB3 vec env's own, else built from the step (see the module docstring)."""
        infos = result.infos.get("sb3_infos") if isinstance(result.infos, dict) else None
        if infos is not None:
            return infos
        if self._episodes is None or len(self._episodes.returns) != len(rewards):
            self._episodes = _Episodes(len(rewards))
        infos = [{} for _ in range(len(rewards))]
        if dones.any():
            final_obs = _numpy(result.final_obs)
            for i, episode in self._episodes.step(rewards, dones).items():
                infos[i] = {"terminal_observation": final_obs[i], "TimeLimit.truncated": bool(truncated[i]),
                            "episode": episode}
        else:
            self._episodes.step(rewards, dones)
        return infos

    def on_rollout_end(self, ctx: Any) -> None:
        if self._in_rollout:
            self._in_rollout = False
            for cb in self.callbacks:
                cb.on_rollout_end()
            self._iterations += 1  # on-policy: SB3 dumps every log_interval iterations, after the rollout
            if getattr(self.model, "algo", "ppo") == "ppo" and self.log_interval > 0 and \
                    self._iterations % self.log_interval == 0:
                self.model.logger.dump(self.model.num_timesteps)

    def on_train_end(self, ctx: Any, result: Any) -> None:
        for cb in self.callbacks:
            cb.on_training_end()

    def close(self) -> None:
        self.model.logger.writer = None
