"""``ray.rllib.env.wrappers.pettingzoo_env``: a PettingZoo game as RLlib's ``MultiAgentEnv``, stepped by the face's
multi-agent training like any other.

:class:`PettingZooEnv` takes an AEC game (one agent moves at a time): ``reset`` and ``step`` return only the next
mover's observation; agents that are done are stepped with ``None`` until a live agent is to move (their last
observation, reward and flags are returned on the way), and ``"__all__"`` is true once no agent is left and all
of them ended that way. :class:`ParallelPettingZooEnv` takes a parallel game (every live agent moves at once):
its dicts are passed through, ``"__all__"`` true when every agent's flag is. Both are RLlib's rules.
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym

from rlchain.rllib.multi_agent import MultiAgentEnv


class _GameWrapper(MultiAgentEnv):
    """A PettingZoo game under RLlib's attribute for it (``game_attribute``: ``env`` or ``par_env``): its agents and
    spaces, read after a first ``reset``; ``close``, ``render`` and ``get_sub_environments`` are the game's."""

    game_attribute: ClassVar[str]

    def __init__(self, env: Any) -> None:
        setattr(self, self.game_attribute, env)
        env.reset()
        self.agents = list(env.agents)  # the game's own order
        self.possible_agents = list(getattr(env, "possible_agents", None) or env.agents)
        self._agent_ids = set(self.agents)
        self.observation_spaces = {aid: env.observation_space(aid) for aid in self.agents}
        self.action_spaces = {aid: env.action_space(aid) for aid in self.agents}
        self.observation_space = gym.spaces.Dict(self.observation_spaces)
        self.action_space = gym.spaces.Dict(self.action_spaces)
        super().__init__()

    @property
    def _game(self) -> Any:
        return getattr(self, self.game_attribute)

    def close(self) -> None:
        self._game.close()

    def render(self) -> Any:
        return self._game.render()

    @property
    def get_sub_environments(self) -> Any:
        return self._game.unwrapped


class PettingZooEnv(_GameWrapper):
    """An AEC PettingZoo game (``env``: e.g. ``rps_v2.env()``) as a turn-based ``MultiAgentEnv``."""

    game_attribute = "env"

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        info = self.env.reset(seed=seed, options=options)
        mover = self.env.agent_selection
        return {mover: self.env.observe(mover)}, info or {}

    def step(self, action: dict) -> tuple[dict, dict, dict, dict, dict]:
        self.env.step(action[self.env.agent_selection])
        obs, rewards, terminateds, truncateds, infos = {}, {}, {}, {}, {}
        while self.env.agents:  # to the next live mover, stepping the done agents out with None
            ob, reward, terminated, truncated, info = self.env.last()
            aid = self.env.agent_selection
            obs[aid], rewards[aid], terminateds[aid], truncateds[aid], infos[aid] = \
                ob, reward, terminated, truncated, info
            if not (self.env.terminations[aid] or self.env.truncations[aid]):
                break
            self.env.step(None)
        gone = not self.env.agents
        terminateds["__all__"] = gone and all(terminateds.values())
        truncateds["__all__"] = gone and all(truncateds.values())
        return obs, rewards, terminateds, truncateds, infos


class ParallelPettingZooEnv(_GameWrapper):
    """A parallel PettingZoo game (``env``: e.g. ``rps_v2.parallel_env()``) as a ``MultiAgentEnv``."""

    game_attribute = "par_env"

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        obs, info = self.par_env.reset(seed=seed, options=options)
        return obs, info or {}

    def step(self, action_dict: dict) -> tuple[dict, dict, dict, dict, dict]:
        obs, rewards, terminateds, truncateds, infos = self.par_env.step(action_dict)
        terminateds = {**terminateds, "__all__": all(terminateds.values())}
        truncateds = {**truncateds, "__all__": all(truncateds.values())}
        return obs, rewards, terminateds, truncateds, infos


__all__ = ["ParallelPettingZooEnv", "PettingZooEnv"]
