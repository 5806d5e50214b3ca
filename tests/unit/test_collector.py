"""The on-policy collector's hooks (rlchain/algos/core/collector.py) on a tiny tensor env: an algorithm's own act
step and per-step hook, RNN states carried and zeroed where an episode ended, no storage, the differentiable
mode keeping the graph through the env, a stop signal."""

from types import SimpleNamespace

import torch

from rlchain.algos.core.collector import CollectedStep, OnPolicyCollector
from rlchain.config.run import RewardShaperConfig
from rlchain.envs.vecenv import StepResult


class LineEnv:
    """``num_envs`` points on a line: obs += action; reward -obs^2; env 0's episode ends every 2nd step."""

    num_envs = 3

    def __init__(self) -> None:
        self.x = torch.zeros(self.num_envs, 1)
        self.steps = 0

    def step(self, actions: torch.Tensor) -> StepResult:
        self.steps += 1
        self.x = self.x + actions
        done = torch.zeros(self.num_envs, dtype=torch.bool)
        done[0] = self.steps % 2 == 0
        return StepResult(self.x, -(self.x ** 2).sum(-1), done, torch.zeros_like(done), self.x, {})


def context(stop_after: int | None = None) -> SimpleNamespace:
    calls = []

    def record_step(result, rows):
        calls.append(rows)
        terminated = torch.as_tensor(result.terminated)
        return result.reward.detach(), terminated, torch.as_tensor(result.truncated), terminated

    return SimpleNamespace(device=torch.device("cpu"), epoch=0, spec=SimpleNamespace(groups=None, to_env=lambda a: a),
                           recorded=calls,
                           stop_requested=lambda: stop_after is not None and len(calls) >= stop_after,
                           to_tensor=torch.as_tensor, record_step=record_step)


def test_own_act_step_and_per_step_hook_carry_states_and_zero_them_at_episode_ends():
    env, ctx, seen = LineEnv(), context(), []
    model = torch.nn.Linear(1, 1)

    def act(t, obs, states, masks):  # an RNN-like state: steps since the episode started
        return {"actions": torch.ones(env.num_envs, 1), "states": (states[0] + 1,), "extra": t}

    collector = OnPolicyCollector(env, model, ctx, SimpleNamespace(horizon_length=4), act=act, to_env=lambda a: a,
                                  on_step=seen.append)
    collector.obs, collector.rnn_states = torch.zeros(3, 1), (torch.zeros(1, 3, 1),)
    assert collector.rollout()
    assert [s.t for s in seen] == [0, 1, 2, 3] and [s.out["extra"] for s in seen] == [0, 1, 2, 3]
    assert all(isinstance(s, CollectedStep) and s.outcome is not None for s in seen)
    assert torch.equal(seen[2].obs, torch.full((3, 1), 2.0))  # what step 2 acted on
    assert collector.rnn_states[0].flatten().tolist() == [0.0, 4.0, 4.0]  # env 0's episode ended at step 4
    assert len(ctx.recorded) == 4 and collector.last_values is None  # recorded every step; no storage, no values
    assert not model.training  # the policy acts in evaluation mode


def test_differentiable_rollout_keeps_the_graph_through_the_env_and_the_model_mode():
    env, ctx, rewards = LineEnv(), context(), []
    policy = torch.nn.Linear(1, 1)
    policy.train()

    def on_step(step):
        rewards.append(step.result.reward)

    collector = OnPolicyCollector(env, policy, ctx, SimpleNamespace(horizon_length=3),
                                  act=lambda t, obs, states, masks: {"actions": policy(obs) + 1.0},
                                  to_env=lambda a: a, read_obs=lambda x: x, on_step=on_step, differentiable=True)
    collector.obs = torch.zeros(3, 1)
    assert collector.rollout()
    torch.stack(rewards).sum().backward()
    assert policy.weight.grad is not None and bool(policy.weight.grad.abs().sum() > 0)
    assert policy.training


def test_a_stop_signal_ends_the_rollout_early():
    env, ctx = LineEnv(), context(stop_after=2)
    collector = OnPolicyCollector(env, torch.nn.Linear(1, 1), ctx, SimpleNamespace(horizon_length=5),
                                  act=lambda t, obs, states, masks: {"actions": torch.zeros(3, 1)},
                                  to_env=lambda a: a, record=lambda result, rows: ctx.record_step(result, rows))
    collector.obs = torch.zeros(3, 1)
    assert not collector.rollout() and env.steps == 2


def test_stored_rewards_are_the_envs_under_the_identity_shaper_and_a_dropped_row_keeps_the_outcome():
    import math

    import gymnasium as gym

    from rlchain.algos.core.storage import RolloutStorage
    from rlchain.envs.vecenv import DROPPED

    class DroppingEnv(LineEnv):
        observation_space = gym.spaces.Box(-math.inf, math.inf, (1,))

        def step(self, actions):
            result = super().step(actions)
            if self.steps == 2:  # env 1's worker died at step 2: its row is dropped
                result.infos[DROPPED] = [False, True, False]
            return result

    env, ctx, seen = DroppingEnv(), context(), []
    storage = RolloutStorage(3, 3, (1,), torch.float32, (1,), torch.float32, 1, 1, torch.device("cpu"))
    identity = RewardShaperConfig()  # the defaults: the identity
    assert identity.identity and not RewardShaperConfig(scale_value=0.1).identity
    cfg = SimpleNamespace(horizon_length=3, reward_shaper=identity, value_bootstrap=False, gamma=0.9)
    act = lambda t, obs, states, masks: {"actions": torch.ones(3, 1), "log_probs": torch.zeros(3),  # noqa: E731
                                         "values": torch.full((3, 1), 7.0), "params": torch.zeros(3, 1)}
    collector = OnPolicyCollector(env, torch.nn.Linear(1, 1), ctx, cfg, storage=storage, act=act,
                                  to_env=lambda a: a, on_step=seen.append)
    collector.obs = torch.zeros(3, 1)
    collector.model.value = lambda obs, states: torch.zeros(obs.shape[0], 1)
    assert collector.rollout()
    assert storage.rewards[:, :, 0].tolist() == [[-1.0, -1.0, -1.0], [-4.0, 7.0, -4.0], [-9.0, -9.0, -9.0]]
    assert seen[1].outcome[0].tolist() == [-4.0, -4.0, -4.0]  # the step's outcome is the env's reward
