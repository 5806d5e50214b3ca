"""A Ray env worker of numpy envs starts without torch: its module, the recipe it is sent and the envs it builds
import neither torch nor rlchain's algorithms (about 3 s of CPU a worker start), and the learner's registry
entries reach it each unpickled on its own first lookup."""

import os
import pickle
import subprocess
import sys

import pytest

from rlchain.envs.examples.goal_reach import GoalReachEnv
from rlchain.envs.ray.ray_worker import EnvRecipe
from rlchain.registry import Deferred, Registry
from tests.conftest import ROOT

# the body of a Ray env worker, as the actor runs it: import the module, unpickle the recipe, build, reset, step;
# torch's first import is reported with the rlchain / tests frames that made it
WORKER = r"""
import pickle, sys, traceback

class Watch:
    def find_spec(self, name, path=None, target=None):
        if name == "torch" and "torch" not in sys.modules:
            frames = [f"{f.filename}:{f.lineno}" for f in traceback.extract_stack() if "rlchain" in f.filename]
            print("torch imported by", frames[-3:])
        return None

sys.meta_path.insert(0, Watch())
from rlchain.envs.ray.ray_worker import EnvWorker
import numpy as np
print("module", "torch" in sys.modules)
worker = EnvWorker(pickle.loads(sys.stdin.buffer.read()), 0, 2, own_process=True)
print("recipe", "torch" in sys.modules)
info = worker.build(3)
obs = worker.reset(3)
actions = np.stack([info["action_space"].sample() for _ in range(2)])
out = pickle.loads(worker.step(pickle.dumps(actions)))
assert obs.shape == (2, *info["observation_space"].shape) and out[0].shape == obs.shape
print("stepped", "torch" in sys.modules, "rlchain.builtins" in sys.modules)
"""


@pytest.mark.parametrize("env_name", ["CartPole-v1", "TestGoalReach-v0"])  # gymnasium's env, rlchain's example
def test_env_worker_builds_and_steps_numpy_envs_without_torch(env_name):
    cloudpickle = pytest.importorskip("cloudpickle")
    recipe = cloudpickle.dumps(EnvRecipe.capture(env_name, {}, "sync"))  # what Ray sends the actor
    out = subprocess.run([sys.executable, "-c", WORKER], input=recipe, capture_output=True, timeout=120,
                         env={**os.environ, "PYTHONPATH": ROOT}, cwd=ROOT)
    text = out.stdout.decode() + out.stderr.decode()
    assert out.returncode == 0, text[-3000:]
    assert text.split("\n")[:3] == ["module False", "recipe False", "stepped False False"], text[-3000:]


def test_a_recipe_sends_each_registry_entry_to_be_unpickled_on_first_lookup():
    recipe = EnvRecipe.capture("CartPole-v1", {}, "sync")
    assert "openai_gym" in recipe.builders and "sync" in recipe.vecenvs  # the learner's tables, built-ins included
    sent = pickle.loads(pickle.dumps(recipe))
    entry = sent.builders["openai_gym"]
    assert isinstance(entry, Deferred) and not isinstance(recipe.builders["openai_gym"], Deferred)
    assert entry.make() == recipe.builders["openai_gym"]  # the same builder, by reference
    assert all(isinstance(v, Deferred) for v in sent.vecenvs.values())
    # a gymnasium entry point a module names travels as its name: gymnasium imports it when it makes that env
    assert sent.gym_specs["TestGoalReach-v0"].entry_point == "rlchain.envs.examples.goal_reach:GoalReachEnv"
    assert recipe.gym_specs["TestGoalReach-v0"].entry_point is GoalReachEnv  # the recipe itself is unchanged


def test_a_deferred_entry_is_made_on_its_first_lookup_and_kept():
    made = []
    table = Registry("thing")
    table.register("lazy", Deferred(lambda: made.append(1) or "entry"))
    table.register("plain", 2)
    assert table.names() == ["lazy", "plain"] and "lazy" in table and made == []  # names need no entry
    assert table.get("lazy") == "entry" and table.get("lazy") == "entry" and made == [1]  # made once
    assert table.get("plain") == 2


def test_an_entry_point_without_a_module_name_travels_unpickled_until_its_env_is_made():
    import gymnasium as gym

    from rlchain.envs.ray.ray_worker import LazyEntryPoint

    gym.register("TestLambdaGoalReach-v0", entry_point=lambda **kw: GoalReachEnv(**kw))  # no module:Name for it
    try:
        sent = pickle.loads(pickle.dumps(EnvRecipe.capture("CartPole-v1", {}, "sync")))
        entry = sent.gym_specs["TestLambdaGoalReach-v0"].entry_point
        assert isinstance(entry, LazyEntryPoint) and entry._entry is None  # not unpickled by the recipe's arrival
        assert pickle.loads(pickle.dumps(entry))._entry is None
        env = gym.make(sent.gym_specs["TestLambdaGoalReach-v0"])
        assert isinstance(env.unwrapped, GoalReachEnv) and entry._entry is not None
        env.close()
    finally:
        gym.registry.pop("TestLambdaGoalReach-v0", None)
