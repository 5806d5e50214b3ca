"""RLlib's deploy pattern on the face: ``RLModule.from_checkpoint(<checkpoint>/learner_group/learner/rl_module)``
gives the trained module without the algorithm; wrong paths end in one line."""

import json

import pytest
import torch

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.checkpoint_files import CONFIG_FILE
from rlchain.rllib.core.rl_module import RLModule
from rlchain.rllib.module_checkpoint import MODULES_PATH, locate, write_module_folders
from rlchain.runs import checkpoint as ckpt


def _checkpoint(root, ids=("default_policy",)):
    root.mkdir()
    (root / CONFIG_FILE).write_text(json.dumps({"algo": "PPO", "config": {"env": "CartPole-v1"}}))
    write_module_folders(str(root), list(ids))
    return root


def test_locate_reads_rllibs_component_paths(tmp_path):
    root = _checkpoint(tmp_path / "ckpt", ["a", "b"])
    modules = root.joinpath(*MODULES_PATH)
    assert locate(modules) == (str(root), None)
    assert locate(modules / "b") == (str(root), "b")
    with pytest.raises(ConfigError, match="'c' is not a module of this checkpoint \\(a, b\\)"):
        locate(modules / "c")
    with pytest.raises(ConfigError, match="a whole checkpoint: pass its module folder"):
        locate(root)
    with pytest.raises(ConfigError, match="not a module folder written by the face's save_to_path") as info:
        locate(tmp_path)
    assert "\n" not in str(info.value)


def test_a_saved_ppo_module_loads_alone_and_acts_as_trained(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = (PPOConfig().environment("CartPole-v1").debugging(seed=1)
            .training(train_batch_size=64, minibatch_size=32, num_epochs=1).build_algo())
    try:
        algo.train()
        obs = torch.randn(5, 4)
        trained = algo.get_module().forward_inference({"obs": obs})["action_dist_inputs"]
        path = algo.save_to_path(str(tmp_path / "ckpt"))
    finally:
        algo.stop()
    reads = []
    read = ckpt.load
    monkeypatch.setattr(ckpt, "load", lambda file, *a, **kw: reads.append(file) or read(file, *a, **kw))
    modules = RLModule.from_checkpoint(tmp_path / "ckpt" / "learner_group" / "learner" / "rl_module")
    assert len(reads) == 1  # the stored config and the weights from one read of the file
    assert list(modules) == ["default_policy"]
    loaded = modules["default_policy"].forward_inference({"obs": obs})["action_dist_inputs"]
    assert torch.allclose(loaded, trained)
    alone = RLModule.from_checkpoint(f"{path}/learner_group/learner/rl_module/default_policy")
    assert len(reads) == 2
    assert torch.allclose(alone.forward_inference({"obs": obs})["action_dist_inputs"], trained)


def test_a_checkpoints_json_is_data(tmp_path):
    """An env id that names a module is not made (gym.make would import it); bad values are one line each."""
    from rlchain.rllib.algorithms.algorithm import Algorithm
    from rlchain.rllib.checkpoint_files import stored_config

    root = _checkpoint(tmp_path / "ckpt")
    (root / CONFIG_FILE).write_text(json.dumps({"algo": "PPO", "config": {"env": "os:system"}}))
    (root / "rlchain_checkpoint.pth").write_bytes(b"")
    with pytest.raises(ConfigError, match="'os:system' is not a registered gymnasium id") as info:
        RLModule.from_checkpoint(root / "learner_group" / "learner" / "rl_module")
    assert "\n" not in str(info.value)
    for stored, key in (([1], ""), ({"config": "CartPole-v1"}, "config"), ({"iteration": "3"}, "iteration"),
                        ({"algo": 7}, "algo")):
        (root / CONFIG_FILE).write_text(json.dumps(stored))
        with pytest.raises(ConfigError, match=f"{CONFIG_FILE}: {key}.*expected") as info:
            stored_config(str(root))
        assert "\n" not in str(info.value)
    (root / CONFIG_FILE).write_text("[" * 5000 + "]" * 5000)
    with pytest.raises(ConfigError, match="nested"):
        Algorithm.from_checkpoint(root)
