"""The Algorithm protocol: what :class:`rlchain.training.loop.Loop` asks of an algorithm.

The Loop owns everything algorithms share -- counters, stop rules, checkpoint cadence, stop
signals, the divergence guard, events, evaluation and the logging of whatever metrics an epoch
returns. An algorithm is a Loop subclass that fills in these hooks, plus a config class and one
registration::

    class MyTrainer(Loop):
        config_class = MyConfig                       # its params.config schema
        metric_tags = {"loss": "losses/loss"}         # update()'s metrics -> TensorBoard tags
        console_fields = (("loss", "loss {:.3g}"),)   # and on the console epoch line
        tunable = ("learning_rate",)                  # what get_params/set_params (PBT) may change

        def collect(self) -> bool: ...                # one epoch of env steps (False: a stop signal came)
        def update(self) -> dict[str, float] | None: ...  # learn; None: rolled back after a NaN

    ALGOS.register("my_algo", MyTrainer)               # in the package's __init__.py

PPO (:mod:`rlchain.algos.ppo.trainer`), SAC and DQN (:mod:`rlchain.algos.off_policy.trainer`), APPO and
IMPALA (:mod:`rlchain.algos.appo.trainer`) are built this way; the Loop never names a loss. An algorithm
that brings its own env runners names them with a classmethod ``build_training_env(params, seed)``,
which the Runner calls instead of building the vectorized env.
"""

from __future__ import annotations

from typing import Any, ClassVar, Protocol, runtime_checkable


@runtime_checkable
class Algorithm(Protocol):
    """The hooks the Loop drives, once per epoch: ``collect`` then ``update``."""

    metric_tags: ClassVar[dict[str, str]]
    """Metric name (a key of :meth:`update`'s result) -> TensorBoard tag. Keys that already look like
    tags (``losses/aux``) are written as they are; other keys are passed to callbacks only."""

    console_fields: ClassVar[tuple[tuple[str, str], ...]]
    """(metric name, format) pairs appended to the console epoch line, when the metric is present."""

    tunable: ClassVar[tuple[str, ...]]
    """Hyperparameters :meth:`set_params` may change between epochs (population-based training)."""

    supports_distributed: ClassVar[bool]
    """Whether ``multi_gpu`` (torchrun data-parallel learning) works for this algorithm."""

    def collect(self) -> bool:
        """Step the envs for one epoch, advancing the Loop's ``obs``; False when a stop signal came
        (the epoch is then not counted)."""

    def update(self) -> dict[str, float] | None:
        """Learn from what :meth:`collect` gathered and count its frames into ``self.frames``;
        returns the epoch's metrics, or None when a divergence was rolled back."""

    def frames_per_epoch(self) -> int:
        """Env frames one epoch adds (the fps of the console line and the TensorBoard tags)."""

    def hyperparams(self) -> dict[str, float]:
        """The live values of :attr:`tunable`."""

    def apply_hyperparam(self, name: str, value: float) -> None:
        """Change one of :attr:`tunable` (called by the Loop between epochs)."""

    def extra_state(self, kind: str) -> dict[str, Any]:
        """What a checkpoint of ``kind`` carries beyond the model, the agent and the counters."""

    def restore_extra(self, state: dict[str, Any]) -> None:
        """Restore what :meth:`extra_state` added."""
