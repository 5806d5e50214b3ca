"""SB3's ``replay_buffer_class=HerReplayBuffer`` with ``replay_buffer_kwargs`` -> rlchain's hindsight replay.

``SAC("MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer, replay_buffer_kwargs=dict(n_sampled_goal=4,
goal_selection_strategy="future"))`` trains with ``config.replay.her: {strategy: future, k: 4}``
(:mod:`rlchain.algos.off_policy.her`): ``n_sampled_goal`` is ``k``, ``goal_selection_strategy`` the strategy
(``"future"`` / ``"final"``, or SB3's ``GoalSelectionStrategy``). :class:`HerReplayBuffer` is the name to pass
(``from rlchain import HerReplayBuffer``); SB3's own class is taken too.
"""

from __future__ import annotations

from typing import Any


class HerReplayBuffer:
    """The marker SB3 scripts pass as ``replay_buffer_class``: rlchain's replay buffer with hindsight goals."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        raise TypeError("HerReplayBuffer is passed as replay_buffer_class=HerReplayBuffer; rlchain builds the buffer")


STRATEGIES = ("future", "final")
KWARGS = ("n_sampled_goal", "goal_selection_strategy", "copy_info_dict", "handle_timeout_termination")


def is_her(value: Any) -> bool:
    """Whether ``value`` is a HerReplayBuffer class (rlchain's, or SB3's by its name) or that name (as a saved
    model keeps it)."""
    return value == "HerReplayBuffer" or isinstance(value, type) and value.__name__ == "HerReplayBuffer"


def her_config(replay_buffer_class: Any, replay_buffer_kwargs: Any) -> dict[str, Any]:
    """The ``config.replay`` block of SB3's replay arguments; ValueError (``name: why``) for what does not map."""
    if replay_buffer_class is None:
        if replay_buffer_kwargs:
            raise ValueError("replay_buffer_kwargs: given without replay_buffer_class=HerReplayBuffer (rlchain's "
                             "replay buffer is built in)")
        return {}
    if not is_her(replay_buffer_class):
        name = getattr(replay_buffer_class, "__name__", repr(replay_buffer_class))
        raise ValueError(f"replay_buffer_class: {name}: rlchain's replay buffer is built in; HerReplayBuffer maps "
                         f"to its hindsight replay (config.replay.her)")
    kwargs = dict(replay_buffer_kwargs or {})
    unknown = [k for k in kwargs if k not in KWARGS]
    if unknown:
        raise ValueError(f"replay_buffer_kwargs: {', '.join(unknown)} not known (HerReplayBuffer takes "
                         f"{', '.join(KWARGS)})")
    k = kwargs.get("n_sampled_goal", 4)
    if isinstance(k, bool) or not isinstance(k, int) or k < 1:
        raise ValueError(f"replay_buffer_kwargs.n_sampled_goal: expected an int >= 1, got {k!r}")
    strategy = kwargs.get("goal_selection_strategy", "future")
    strategy = str(getattr(strategy, "name", strategy)).lower()  # SB3's GoalSelectionStrategy enum: its name
    if strategy not in STRATEGIES:
        raise ValueError(f"replay_buffer_kwargs.goal_selection_strategy: '{strategy}' has no rlchain counterpart "
                         f"(rlchain's hindsight replay: {', '.join(STRATEGIES)})")
    if kwargs.get("copy_info_dict"):
        raise ValueError("replay_buffer_kwargs.copy_info_dict: rlchain recomputes rewards from the goals only "
                         "(compute_reward(achieved, desired, None))")
    return {"her": {"strategy": strategy, "k": int(k)}}
