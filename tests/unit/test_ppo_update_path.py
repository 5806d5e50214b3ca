"""The PPO update path a reader follows: from the loop's ``train`` to the clipped surrogate is at most 4 call
frames (the loop's guarded update, the algorithm's update -- PPO's, APPO's, multi-policy PPO's --, PPOAgent.update
with the minibatch loop, the loss), and an algorithm builds its collaborators whole (no attribute set on them
after construction)."""

import ast
import copy
import os
import sys

import pytest
import yaml

from rlchain import Runner
from rlchain.algos.core import losses
from rlchain.training.loop import Loop
from tests.conftest import BASE, CONFIGS, ROOT

MAX_FRAMES = 4


def _frames_from_train_to_clip(config: dict) -> list[str]:
    """The functions on the stack between ``Loop.train`` and the first call of ``policy_loss`` (exclusive)."""
    target, train = losses.policy_loss.__code__, Loop.train.__code__
    chain: list[str] = []

    def profile(frame, event, arg):
        if event != "call" or frame.f_code is not target or chain:
            return
        caller = frame.f_back
        while caller is not None and caller.f_code is not train:
            chain.append(f"{os.path.basename(caller.f_code.co_filename)}:{caller.f_code.co_qualname}")
            caller = caller.f_back
        if caller is None:
            chain.append("<no Loop.train on the stack>")

    sys.setprofile(profile)
    try:
        Runner().load(config).train()
    finally:
        sys.setprofile(None)
    return chain


def _config(name: str | None, tmp_path, **config) -> dict:
    raw = copy.deepcopy(BASE) if name is None else yaml.safe_load(open(os.path.join(CONFIGS, name)))
    raw["params"]["config"].update(config, train_dir=str(tmp_path), print_stats=False)
    return raw


@pytest.mark.parametrize("name,config,update", [
    (None, {"max_epochs": 1}, "ppo.py:PPO.update"),
    ("appo_cartpole.yaml", {"max_epochs": 1}, "appo.py:APPO.update"),
    ("ppo_pz_simple_tag.yaml", {"max_epochs": 1, "num_actors": 2, "minibatch_size": 100},
     "multi_policy.py:MultiPolicyPPO.update"),
])
def test_from_the_loop_to_the_clipped_loss_is_at_most_four_frames(tmp_path, name, config, update):
    chain = _frames_from_train_to_clip(_config(name, tmp_path, **config))
    assert chain and "<no Loop.train on the stack>" not in chain, chain
    assert len(chain) <= MAX_FRAMES, " <- ".join(chain)
    assert chain == ["loss.py:ppo_loss", "agent.py:PPOAgent.update", update, "loop.py:Loop._guarded_update"], chain


def _attributes_set_on_collaborators(path: str) -> list[str]:
    """``<name>.<part>.<attr> = ...`` and ``<name>.<attr> = ...`` assignments, ``<name>`` not ``self`` / ``cls``
    (an attribute set on a collaborator: ``self.collector.obs``, ``learner.agent.active``, ``model.bptt_length``,
    ``ctx.tracker``)."""
    found = []
    for node in ast.walk(ast.parse(open(path).read())):
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] \
            if isinstance(node, (ast.AugAssign, ast.AnnAssign)) else []
        for target in targets:
            for item in target.elts if isinstance(target, ast.Tuple) else [target]:
                if not isinstance(item, ast.Attribute):
                    continue
                owner = item.value
                if isinstance(owner, ast.Attribute) and isinstance(owner.value, ast.Name):
                    name = f"{owner.value.id}.{owner.attr}.{item.attr}"
                elif isinstance(owner, ast.Name) and owner.id not in ("self", "cls"):
                    name = f"{owner.id}.{item.attr}"
                else:
                    continue
                found.append(f"{os.path.relpath(path, ROOT)}:{item.lineno}: {name}")
    return found


# the run's frame counter, which the off-policy stepper advances as it collects (counts_frames_while_collecting); live
# values population-based training changes between epochs, each in the part that reads it (the parts whose
# config is the run's old one, the adaptive schedule's threshold, the replay's n-step gamma); a delay line emptied at
# a rollback; SAC's model setting the config's log_std_bounds on the network it was given (a network builder's key
# rl_games reads from the algo's config, left as it is); objects a function builds and returns (the mirrored copy
# of a rollout) or changes by its job (a module's forward compiled in place); the model's observation view, which
# ObservationModel.read_view sets for the builder, since rl_games' factory signature has no place for it; what an
# autograd Function's backward needs beyond tensors, on the context torch's API gives it for that (ctx.step); a
# parameter's gradient cleared before a backward pass, as torch's zero_grad(set_to_none=True) does (p.grad)
ALLOWED = {"ctx.frames", "part.cfg", "self.schedule.kl_threshold", "self.buffer.gamma", "self.delay.line",
           "network.actor.log_std_bounds", "out.num_envs", "out.obs", "out.actions", "out.params",
           "out.action_masks", "out.states", "out.resets", "module.forward", "ctx.step",
           "p.grad"}


def test_no_algorithm_or_model_sets_an_attribute_on_a_collaborator():
    found = []
    for part in ("algos", "models"):
        for folder, _, names in os.walk(os.path.join(ROOT, "rlchain", part)):
            for name in sorted(names):
                if name.endswith(".py"):
                    found += [hit for hit in _attributes_set_on_collaborators(os.path.join(folder, name))
                              if hit.split(": ")[-1] not in ALLOWED]
    assert not found, found
