"""A resumed run reads its checkpoint once and loads the weights once: the Runner loads them into the model
before the algorithm is built (Loop(resuming=True)), so the first restore keeps them; any later restore (PBT's
exploit) loads the weights of the checkpoint it is given."""

import torch

from rlchain import Runner
from rlchain.algos.ppo.ppo import PPO
from rlchain.envs.factory import build_env
from rlchain.models.build import build_model
from rlchain.runs import checkpoint as ckpt
from rlchain.runs.logging import TrainLogger
from rlchain.training.loop import Loop
from tests.conftest import CONFIGS


def _loop(resuming):
    small = ["params.config.num_actors=2", "params.config.horizon_length=4", "params.config.minibatch_size=8"]
    params = Runner().load(f"{CONFIGS}/ppo_cartpole.yaml", small).params
    env = build_env(params, 2, 0)
    model = build_model(params, env, torch.device("cpu"))
    return Loop(params, PPO, env, model, torch.device("cpu"), None, TrainLogger(None, False), 0, {},
                resuming=resuming), env


def test_the_first_restore_keeps_the_preloaded_weights_and_a_later_one_loads_its_own(monkeypatch):
    loop, env = _loop(resuming=True)
    try:
        state = loop.checkpoints.state_dict("last")
        loads = []
        real = ckpt.load_model_state
        monkeypatch.setattr(ckpt, "load_model_state", lambda *args: (loads.append(args[2]), real(*args)))
        loop.restore(state, "first.pth")
        assert loads == []  # the Runner loaded them before building the algorithm
        loop.restore(state, "exploit.pth")
        assert loads == ["exploit.pth"]
    finally:
        env.close()


def test_a_loop_built_without_the_weights_loads_them_on_restore(monkeypatch):
    loop, env = _loop(resuming=False)
    try:
        loads = []
        real = ckpt.load_model_state
        monkeypatch.setattr(ckpt, "load_model_state", lambda *args: (loads.append(args[2]), real(*args)))
        loop.restore(loop.checkpoints.state_dict("last"), "trial.pth")
        assert loads == ["trial.pth"]
    finally:
        env.close()
