"""compile_update through real PPO epochs: the compiled minibatch step learns what the eager one does."""

import os

import pytest

from tests.conftest import CONFIGS, ppo_epochs

pytestmark = pytest.mark.smoke

KEYS = ("a_loss", "c_loss", "entropy", "kl", "clip_frac", "grad_norm")


def _epochs(compiled: bool, epochs: int = 2) -> list[dict[str, float]]:
    """Same-seed PPO epochs on TorchCartPole at 256 envs; the stats of each update."""
    overrides = ["params.config.num_actors=256", "params.config.minibatch_size=1024", "params.config.print_stats=false",
                 f"params.config.compile_update={compiled}"]
    out, ppo = ppo_epochs(os.path.join(CONFIGS, "ppo_torch_cartpole.yaml"), overrides, 256, epochs)
    assert ppo.agent.mode == ("compiled" if compiled else "eager")  # the compiled region ran, or not
    return out


def test_compiled_update_matches_eager_per_epoch():
    eager, compiled = _epochs(False), _epochs(True)
    for a, b in zip(eager, compiled):
        for key in KEYS:
            assert b[key] == pytest.approx(a[key], rel=1e-4, abs=1e-6), key
