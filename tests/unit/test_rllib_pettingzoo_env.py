"""``ray.rllib.env.wrappers.pettingzoo_env`` on the face: PettingZoo's rock-paper-scissors as RLlib's
``MultiAgentEnv`` (the AEC game one mover at a time, the parallel game all at once), and as the face's
multi-agent env (its agents and per-agent spaces)."""

import gymnasium as gym
import pytest

from rlchain.rllib.env.multi_agent_env import MultiAgentEnv
from rlchain.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv, PettingZooEnv

rps_v2 = pytest.importorskip("pettingzoo.classic.rps_v2")


def test_aec_game_returns_only_the_next_mover_until_every_agent_is_done():
    env = PettingZooEnv(rps_v2.env(num_actions=3, max_cycles=4))
    assert isinstance(env, MultiAgentEnv) and env.possible_agents == ["player_0", "player_1"]
    assert env.get_observation_space("player_1") == gym.spaces.Discrete(4)
    assert env.action_space == gym.spaces.Dict({"player_0": gym.spaces.Discrete(3),
                                                "player_1": gym.spaces.Discrete(3)})
    obs, infos = env.reset(seed=1)
    assert list(obs) == ["player_0"] and isinstance(infos, dict)
    movers, returns = [], {"player_0": 0.0, "player_1": 0.0}
    for _ in range(100):
        action = {aid: 0 if aid == "player_0" else 1 for aid in obs}  # paper beats rock every round
        obs, rewards, terminateds, truncateds, _ = env.step(action)
        movers.append(sorted(obs))
        for aid, reward in rewards.items():
            returns[aid] += reward
        if truncateds["__all__"]:
            break
        assert not terminateds["__all__"] and len(obs) == 1
    assert movers[:3] == [["player_1"], ["player_0"], ["player_1"]]
    assert len(movers) == 8 and movers[-1] == ["player_0", "player_1"]  # 4 rounds of 2 moves; both step out at the end
    assert returns["player_1"] > 0 > returns["player_0"] and returns["player_0"] == -returns["player_1"]


def test_parallel_game_passes_its_dicts_through_with_all():
    env = ParallelPettingZooEnv(rps_v2.parallel_env(max_cycles=3))
    obs, _ = env.reset(seed=1)
    assert sorted(obs) == ["player_0", "player_1"]
    rounds = 0
    while rounds < 10:
        rounds += 1
        obs, rewards, terminateds, truncateds, _ = env.step({"player_0": 2, "player_1": 1})  # scissors beat paper
        assert rewards == {"player_0": 1, "player_1": -1}
        if truncateds["__all__"]:
            break
        assert terminateds["__all__"] is False
    assert rounds == 3 and env.get_sub_environments is env.par_env.unwrapped


@pytest.mark.parametrize("wrapper, make, attribute", [(PettingZooEnv, "env", "env"),
                                                      (ParallelPettingZooEnv, "parallel_env", "par_env")])
def test_both_wrappers_render_close_and_expose_the_game_under_rllibs_attribute(wrapper, make, attribute):
    game = getattr(rps_v2, make)(max_cycles=2)
    env = wrapper(game)
    assert getattr(env, attribute) is game and env.get_sub_environments is game.unwrapped
    assert env.get_observation_space("player_0") == game.observation_space("player_0")
    env.reset(seed=1)
    closed = []
    game.render, game.close = (lambda: "the game's frame"), (lambda: closed.append(True))
    assert env.render() == "the game's frame"
    env.close()
    assert closed == [True]
