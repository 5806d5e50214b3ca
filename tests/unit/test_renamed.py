"""Names that changed stay importable for one release, each with a DeprecationWarning naming the new one."""

import importlib

import pytest

import rlchain  # noqa: F401  (registers the built-ins)

RENAMED = [
    ("rlchain.config.ppo", "TrainConfig", "rlchain.config.ppo", "PPOConfig"),
    ("rlchain.config.schema", "TrainConfig", "rlchain.config.ppo", "PPOConfig"),
    ("rlchain.config.resolve", "RunContext", "rlchain.config.resolve", "ProcessContext"),
    ("rlchain.algos.ppo.ppo", "OnPolicyTrainer", "rlchain.algos.ppo.ppo", "PPO"),
    ("rlchain.algos.appo.appo", "APPOTrainer", "rlchain.algos.appo.appo", "APPO"),
    ("rlchain.algos.appo.appo", "ImpalaTrainer", "rlchain.algos.appo.appo", "IMPALA"),
    ("rlchain.algos.distill.distill", "DistillTrainer", "rlchain.algos.distill.distill", "Distill"),
    ("rlchain.algos.multi_policy.multi_policy", "MultiPolicyTrainer", "rlchain.algos.multi_policy.multi_policy",
     "MultiPolicyPPO"),
]


@pytest.mark.parametrize("module, old, new_module, new", RENAMED)
def test_an_old_name_is_the_new_object_with_a_warning(module, old, new_module, new):
    target = getattr(importlib.import_module(new_module), new)
    with pytest.warns(DeprecationWarning, match=rf"{old} is renamed {new}"):
        assert getattr(importlib.import_module(module), old) is target


def test_an_unknown_name_is_still_an_attribute_error():
    with pytest.raises(AttributeError, match="TrainConfg"):
        _ = importlib.import_module("rlchain.config.ppo").TrainConfg


def test_no_built_in_algorithm_class_is_named_trainer():
    from rlchain.registry import ALGOS

    assert not [name for name in ALGOS.names() if ALGOS.get(name).__name__.endswith("Trainer")]


@pytest.mark.parametrize("old_module, new_module, name", [
    ("rlchain.algos.base.collector", "rlchain.algos.core.collector", "OnPolicyCollector"),
    ("rlchain.algos.base.stepper", "rlchain.algos.core.stepper", "OffPolicyStepper"),
])
def test_a_moved_module_still_serves_its_names_with_a_warning(old_module, new_module, name):
    target = getattr(importlib.import_module(new_module), name)
    with pytest.warns(DeprecationWarning, match=rf"is renamed {new_module}.{name}"):
        assert getattr(importlib.import_module(old_module), name) is target
