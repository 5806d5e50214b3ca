"""The Algorithm protocol: what the training loop (:class:`rlchain.training.loop.Loop`) asks of an algorithm.

The Loop holds an algorithm and owns everything algorithms share -- counters, stop rules, checkpoint
cadence, stop signals, the divergence guard, events, evaluation and the logging of whatever metrics
an epoch returns. It builds the algorithm with the run's :class:`~rlchain.algos.base.context.RunContext`
and drives it, once per epoch: ``collect`` then ``update``. A new algorithm is one folder, one config
class and one registration line::

    class MyAlgorithm(AlgorithmBase):                 # AlgorithmBase: the optional hooks' defaults
        config_class = MyConfig                       # its params.config schema
        metric_tags = {"loss": "losses/loss"}         # update()'s metrics -> TensorBoard tags
        console_fields = (("loss", "loss {:.3g}"),)   # and on the console epoch line
        tunable = ("learning_rate",)                  # what get_params/set_params (PBT) may change

        def __init__(self, params, env, model, ctx):  # build the agent, its storage, its DivergenceGuard
            ...
        def collect(self) -> bool: ...                # one epoch of env steps (False: a stop signal came)
        def update(self) -> dict[str, float] | None: ...  # learn; None: nothing learnt

        def frames_per_epoch(self) -> int: ...

    model_builder.register_algo("my_algo", MyAlgorithm)   # user code (rlchain/builtins.py for a built-in)

PPO (:mod:`rlchain.algos.ppo.ppo`), SAC and DQN (:mod:`rlchain.algos.off_policy.off_policy`), APPO and
IMPALA (:mod:`rlchain.algos.appo.appo`) and multi-policy PPO are built this way; the Loop never names a
loss. An algorithm that brings its own env runners returns them from ``build_training_env``.
"""

from __future__ import annotations

from typing import Any, ClassVar, Protocol, runtime_checkable

import torch

from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import DivergenceGuard
from rlchain.algos.core.adam_agent import Agent
from rlchain.algos.core.collector import OnPolicyCollector
from rlchain.config.params import Params
from rlchain.envs.factory import build_env
from rlchain.envs.obs_dict import ObsDict
from rlchain.envs.spec import EnvSpec
from rlchain.envs.vecenv import VecEnv


@runtime_checkable
class Algorithm(Protocol):
    """The required core: the hooks the Loop drives every run. ``model``, ``agent`` (the
    :class:`~rlchain.algos.core.adam_agent.Agent` contract: ``state_dict`` / ``load_state_dict`` of the optimizer
    and live values, ``lr``, ``scale_lr``) and ``divergence`` are what the Loop checkpoints and rolls back.
    A class attribute ``config_class`` names its ``params.config`` dataclass (PPOConfig when absent).

    Optional parts, each declared where the loop reads it and found by its methods: what a checkpoint carries
    beyond the model and the agent (:class:`rlchain.training.saving.CheckpointState`: ``extra_state`` /
    ``restore_extra``), where the algorithm stands in the envs' episodes (:class:`rlchain.training.resume.
    ResumePosition`: ``position_state``, put back by the algorithm's own ``start``) and an update a stop signal
    may interrupt (:class:`rlchain.training.loop.InterruptibleUpdate`). :class:`AlgorithmBase` has all three."""

    metric_tags: ClassVar[dict[str, str]]
    """Metric name (a key of :meth:`update`'s result) -> TensorBoard tag. Keys that already look like
    tags (``losses/aux``) are written as they are; other keys are passed to callbacks only."""

    console_fields: ClassVar[tuple[tuple[str, str], ...]]
    """(metric name, format) pairs appended to the console epoch line, when the metric is present."""

    tunable: ClassVar[tuple[str, ...]]
    """Hyperparameters :meth:`apply_hyperparam` may change between epochs (population-based training)."""

    supports_distributed: ClassVar[bool]
    """Whether ``multi_gpu`` (torchrun data-parallel learning) works for this algorithm."""

    self_play: ClassVar[bool]
    """Whether ``self_play_config`` loads frozen opponents into the env (the Loop's SelfPlayCallback)."""

    envs_idle_in_update: ClassVar[bool]
    """Whether the envs wait during :meth:`update` (its gradient steps then take ``update_threads``)."""

    counts_frames_while_collecting: ClassVar[bool]
    """Whether the algorithm adds each env step to ``ctx.frames`` as it collects (the off-policy stepper);
    otherwise the Loop adds :meth:`frames_per_epoch` once :meth:`update` returned the epoch's metrics."""
    ctx: RunContext
    model: torch.nn.Module
    agent: Agent
    divergence: DivergenceGuard | None

    @classmethod
    def check_config(cls, params: Params, spec: EnvSpec) -> None:
        """Checks of the config against the env, before the model is built (PPO: the minibatch)."""

    @classmethod
    def build_training_env(cls, params: Params, seed: int | None) -> Any:
        """The training env (a vectorized env, or APPO's runners)."""

    def start(self) -> None:
        """Training starts (after a resume restored its state): reset the envs, start runners."""

    def collect(self) -> bool:
        """Step the envs for one epoch; False when a stop signal came (the epoch is then not counted;
        the learner must not have changed: a stop checkpoint holds the last epoch boundary)."""

    def update(self) -> dict[str, float] | None:
        """Learn from what :meth:`collect` gathered; returns the epoch's metrics, or None when there was nothing
        to count (the epoch then does not count, nor do its frames)."""

    def frames_per_epoch(self) -> int:
        """Env frames one epoch adds: what the Loop counts into ``ctx.frames`` after :meth:`update` (unless
        :attr:`counts_frames_while_collecting`), the fps of the console line and the TensorBoard tags."""

    def epoch_seconds(self, collect_s: float, update_s: float) -> tuple[float, float]:
        """(rollout, update) seconds of the epoch from the time spent in collect and in update."""

    def end_epoch(self, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        """After the Loop logged and checkpointed the epoch (extra scalars, self-play snapshots)."""

    def snapshot_due(self) -> bool:
        """Whether the divergence guard snapshots the learner after this epoch."""

    def restart_episodes(self) -> None:
        """After a rollback to the last snapshot: every env starts a fresh episode."""

    def learners(self) -> list[tuple[torch.nn.Module, Any]]:
        """(model, agent) pairs that train: under torchrun every rank starts from rank 0's."""

    def hyperparams(self) -> dict[str, float]:
        """The live values of :attr:`tunable`."""

    def apply_hyperparam(self, name: str, value: float) -> None:
        """Change one of :attr:`tunable` (called by the Loop between epochs)."""

    def close(self) -> None:
        """Release what the algorithm opened (not the training env: its builder closes it)."""


class AlgorithmBase:
    """Defaults for the optional hooks of :class:`Algorithm`; an algorithm sets ``self.ctx``,
    ``self.cfg``, ``self.env``, ``self.model``, ``self.agent`` and ``self.divergence`` and writes
    ``collect`` / ``update`` / ``frames_per_epoch``. Not a loop: the Loop holds it."""

    metric_tags: ClassVar[dict[str, str]] = {}
    console_fields: ClassVar[tuple[tuple[str, str], ...]] = ()
    tunable: ClassVar[tuple[str, ...]] = ()
    supports_distributed: ClassVar[bool] = False
    self_play: ClassVar[bool] = False
    envs_idle_in_update: ClassVar[bool] = True
    counts_frames_while_collecting: ClassVar[bool] = False
    # update() may raise UpdateInterrupted between minibatches on a stop signal (the Loop then puts back
    # the learner of the epoch boundary); an algorithm without it finishes its update first
    interruptible_update: ClassVar[bool] = False

    def __init__(self, params: Params, env: VecEnv, model: torch.nn.Module, ctx: RunContext) -> None:
        self.params, self.env, self.model, self.ctx = params, env, model, ctx
        self.cfg = ctx.cfg
        self.device = ctx.device
        self.num_envs = env.num_envs
        self.agent: Any = None
        self.divergence: DivergenceGuard | None = None
        # an on-policy algorithm's collector: where the envs stand (the next observations, RNN states) lives there
        self.collector: OnPolicyCollector | None = None

    @classmethod
    def check_config(cls, params: Params, spec: EnvSpec) -> None:
        """No checks beyond the config's own (PPO checks its minibatch against the env's agents)."""
        return None

    @classmethod
    def build_training_env(cls, params: Params, seed: int | None) -> Any:
        """The vectorized env of the config (``num_actors`` envs, Ray workers with ``env_runners``)."""
        return build_env(params, params.config.num_actors, seed, runners=True)

    def start(self) -> None:
        """Reset the envs (their first observations placed in the collector), or after a restore that carried
        the envs' state put them back where the checkpoint left them."""
        if not self.resume_position():
            self.collector.place(self.ctx.reset_envs())

    def resume_position(self) -> bool:
        """After a restore with the envs' state: restore them and this algorithm's position; False when
        there is none (a fresh run, an old checkpoint, an env that cannot give its state)."""
        position = self.ctx.resume_envs()
        if position is None:
            return False
        self.load_position(position)
        return True

    def position_state(self) -> dict[str, Any] | None:
        """The observations the next epoch acts on and, when the collector carries them, the RNN states and
        their episode-start flags (copies); None before ``start`` or without a collector."""
        collector = self.collector
        if collector is None or collector.obs is None:
            return None
        if not collector.carries_states:
            return {"obs": position_copy(collector.obs)}
        return {"obs": position_copy(collector.obs), "rnn_states": position_copy(tuple(collector.rnn_states)),
                "resets": position_copy(collector.resets)}

    def load_position(self, position: dict[str, Any]) -> None:
        """Put back :meth:`position_state` on the training device (Dict observations per key)."""
        device = self.device
        states = position_on(tuple(position["rnn_states"]), device) if "rnn_states" in position else None
        resets = position_on(position["resets"], device) if "resets" in position else None
        self.collector.place(position_on(position["obs"], device), states, resets)

    def epoch_seconds(self, collect_s: float, update_s: float) -> tuple[float, float]:
        """(rollout, update) seconds: the time in collect and in update, as they are."""
        return collect_s, update_s

    def end_epoch(self, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        """Nothing after the Loop's logging and checkpoints."""
        return None

    def snapshot_due(self) -> bool:
        """The divergence guard snapshots the learner after every epoch."""
        return True

    def restart_episodes(self) -> None:
        """Drop the running episodes' statistics, reset the envs, zero the RNN states."""
        self.ctx.tracker.reset_running()
        self.collector.place(self.ctx.reset_envs())
        self.collector.reset_states()

    def learners(self) -> list[tuple[torch.nn.Module, Any]]:
        """The model and its agent."""
        return [(self.model, self.agent)]

    def progress(self, epoch_frames: int | None = None) -> float:
        """Training progress in [0, 1] at the end of this epoch (:meth:`RunContext.progress`)."""
        return self.ctx.progress(self.frames_per_epoch() if epoch_frames is None else epoch_frames)

    def hyperparams(self) -> dict[str, float]:
        """The live values of :attr:`tunable`: the config's, under the agent's own live ones when it keeps
        some (``agent.live_hyperparams()``: the learning rate its schedules and rollbacks change)."""
        live = getattr(self.agent, "live_hyperparams", dict)()
        return {**{name: getattr(self.cfg, name) for name in self.tunable}, **live}

    def apply_hyperparam(self, name: str, value: float) -> None:
        """Change one tunable value: a live one the agent holds goes to it (``agent.set_hyperparam`` returns
        True when it alone keeps it); any other becomes a config field: the run's config becomes a copy holding
        it, the algorithm's parts (agents, guards) that read the old one read the new one, and the agent hears
        of it (``agent.config_changed()``: a captured CUDA graph holds the old value)."""
        set_live = getattr(self.agent, "set_hyperparam", None)
        if set_live is not None and set_live(name, value):
            return
        old, new = self.ctx.replace_config(name, value)
        for part in [self, *vars(self).values()]:
            own = getattr(part, "__dict__", None)  # their own attribute only: no proxy's __getattr__ runs
            if isinstance(own, dict) and own.get("cfg") is old:
                part.cfg = new
        getattr(self.agent, "config_changed", lambda: None)()

    def extra_state(self, kind: str) -> dict[str, Any]:
        """Nothing beyond the model, the agent and the counters."""
        return {}

    def restore_extra(self, state: dict[str, Any]) -> None:
        """Nothing to restore beyond what the Loop restores."""
        return None

    def close(self) -> None:
        """Nothing opened besides the training env (which its builder closes)."""
        return None


def position_copy(x: Any) -> Any:
    """A detached copy of a tensor, or of each tensor of a tuple / dict (anything else as it is), as a checkpoint
    keeps it: an ObsDict becomes a plain dict, since a checkpoint is read back as plain data types only."""
    if isinstance(x, torch.Tensor):
        return x.detach().clone()
    if isinstance(x, (tuple, list)):
        return type(x)(position_copy(v) for v in x)
    if isinstance(x, dict):
        return {k: position_copy(v) for k, v in x.items()}
    return x


def position_on(x: Any, device: torch.device) -> Any:
    """:func:`position_copy`'s result back on ``device``: a tensor moved, a tuple / list element by element, and
    a dict -- Dict observations saved per key -- back as an :class:`ObsDict` of (N, ...) tensors."""
    if isinstance(x, torch.Tensor):
        return x.to(device)
    if isinstance(x, (tuple, list)):
        return type(x)(position_on(v, device) for v in x)
    if isinstance(x, dict):
        return ObsDict({k: position_on(v, device) for k, v in x.items()}, getattr(x, "batch_dims", 1))
    return x
