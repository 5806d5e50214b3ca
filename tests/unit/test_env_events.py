"""config.events as callbacks (rlchain/training/env_events.py): train functions every N env steps, eval
functions after every N-th evaluation, EmbodiChain's contract env handed to them."""

from types import SimpleNamespace

from rlchain.envs.backends.embodichain_env import EmbodiChainVecEnv
from rlchain.training.env_events import EvalEvent, TrainEvent, event_callbacks

CALLS = []


def record(env, env_ids, **params):
    CALLS.append((env, env_ids, params))


def test_train_event_every_n_steps_once_per_step_and_with_the_contract_env():
    CALLS.clear()
    inner = SimpleNamespace(num_envs=2, device="cpu", single_action_space=None, action_space=None)
    ctx = SimpleNamespace(training_env=EmbodiChainVecEnv.__new__(EmbodiChainVecEnv))  # a CallbackContext's face
    ctx.training_env.__dict__["env"] = inner
    event = TrainEvent(record, 3, {"k": 1})
    for _ in range(7):
        event.on_env_step(ctx, None, None, slice(0, 2))
        event.on_env_step(ctx, None, None, slice(2, 4))  # a second env group of the same step
    assert CALLS == [(inner, None, {"k": 1})] * 2


def test_eval_event_every_nth_evaluation_and_config_entries():
    CALLS.clear()
    ctx = SimpleNamespace(training_env="env")
    event = EvalEvent(record, 2, {})
    for _ in range(5):
        event.on_evaluation(ctx, None)
    assert len(CALLS) == 2
    spec = SimpleNamespace(func="tests.unit.test_env_events:record", phase="eval", interval_step=1, params={})
    (callback,) = event_callbacks([spec], True, SimpleNamespace(source="cfg.json"))
    assert isinstance(callback, EvalEvent)
