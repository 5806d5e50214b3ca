"""params.update_threads in real runs: PPO's and SAC's updates run with it, the rollout without."""

import importlib
import os

import pytest
import torch

from rlchain import Runner

CONFIGS = os.path.join(os.path.dirname(__file__), "..", "..", "rlchain", "configs")


@pytest.mark.parametrize("config, agent_module, agent_class", [
    ("ppo_cartpole.yaml", "rlchain.algos.ppo.agent", "PPOAgent"),
    ("sac_pendulum.yaml", "rlchain.algos.off_policy.sac_agent", "SACAgent"),
])
def test_training_updates_run_with_update_threads(tmp_path, monkeypatch, config, agent_module, agent_class):
    """A real run: the agent's update sees update_threads, the rollout the rollout count."""
    cls = getattr(importlib.import_module(agent_module), agent_class)
    seen = []
    original = cls.update

    def spy(self, *args, **kwargs):
        seen.append(torch.get_num_threads())
        return original(self, *args, **kwargs)

    monkeypatch.setattr(cls, "update", spy)
    before = torch.get_num_threads()
    overrides = [f"params.config.train_dir={tmp_path}", "params.config.max_epochs=2", "params.torch_threads=1",
                 "params.update_threads=2", "params.config.print_stats=false"]
    if config.startswith("sac"):
        overrides += ["params.config.num_warmup_frames=0", "params.config.max_epochs=3"]
    try:
        Runner().load(os.path.join(CONFIGS, config), overrides).train()
        after = torch.get_num_threads()
    finally:
        torch.set_num_threads(before)
    assert seen and set(seen) == {min(2, os.cpu_count() or 1)}
    assert after == 1
