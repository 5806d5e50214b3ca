"""RLlib's ``FlattenObservations`` connector as a setting: the face's envs already hand every network flat
observations (gymnasium's ``flatten``: a Dict's keys in sorted order, Box entries raveled, Discrete one-hot, as
RLlib's connector flattens them), so returned by an ``env_to_module_connector`` function it asks for nothing more
(:func:`rlchain.rllib.obs_filter.filter_keys` reads it); it runs nothing."""

from __future__ import annotations

from collections.abc import Collection
from typing import Any


class FlattenObservations:
    """RLlib's observation flattener; its arguments are kept for the translation to read."""

    def __init__(self, *, multi_agent: bool = False, agent_ids: Collection[Any] | None = None,
                 as_learner_connector: bool = False, **kwargs: Any) -> None:
        self.multi_agent = multi_agent
        self.agent_ids = None if agent_ids is None else set(agent_ids)
        self.as_learner_connector = as_learner_connector

    def __repr__(self) -> str:
        return f"FlattenObservations(multi_agent={self.multi_agent!r}, agent_ids={self.agent_ids!r})"
