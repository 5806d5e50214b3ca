"""RLlib's ``MultiAgentEnv`` name, so a script that defines a subclass imports; training one through the face is
refused in one line (rlchain trains PettingZoo envs with several policies: docs/multi_agent.md)."""

from __future__ import annotations

import gymnasium as gym


class MultiAgentEnv(gym.Env):
    """RLlib's multi-agent env base (agents' dicts of observations, rewards, terminateds, truncateds)."""

    possible_agents: list = []
    agents: list = []
    observation_spaces: dict = {}
    action_spaces: dict = {}

    def get_observation_space(self, agent_id):
        return self.observation_spaces[agent_id]

    def get_action_space(self, agent_id):
        return self.action_spaces[agent_id]
