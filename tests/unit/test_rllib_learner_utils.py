"""``ray.rllib.core.learner`` on the face (rlchain/rllib/core/learner): the target-network helpers RLlib's example
RLModules import work as RLlib's; its Learner classes are a one-line ImportError; any other name is an
AttributeError (as on any module, for pickle's module search)."""

import pickle

import pytest
import torch

from rlchain.rllib.alias import FaceImportError
from rlchain.rllib.core.learner.utils import make_target_network, update_target_network


def test_target_network_is_a_frozen_copy_updated_by_polyak():
    main = torch.nn.Linear(3, 2)
    target = make_target_network(main)
    assert target is not main and all(not p.requires_grad for p in target.parameters())
    assert torch.equal(target.weight, main.weight) and main.weight.requires_grad
    with torch.no_grad():
        main.weight.add_(1.0)
    before = target.weight.clone()
    update_target_network(main_module=main, target_module=target, tau=0.25)
    assert torch.allclose(target.weight, 0.75 * before + 0.25 * main.weight)
    with pytest.raises(ValueError, match="torch.nn.Module"):
        make_target_network([main])


def test_learner_classes_are_one_line_and_other_names_attribute_errors():
    import rlchain.rllib.core.learner as learner

    for name in ("Learner", "TorchLearner", "LearnerGroup"):
        with pytest.raises(FaceImportError, match="Learner subclasses are not run") as info:
            getattr(learner, name)
        assert "\n" not in str(info.value)
    assert getattr(learner, "torch", None) is None
    pickle.whichmodule(object(), "torch")
