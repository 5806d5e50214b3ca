"""Learning tier (slow): self-play on the race duel beats a random and a fixed-heuristic opponent."""

import os

import pytest

from rlchain import Runner
from rlchain.envs.examples.duel import play_duel
from rlchain.training.events import Callback
from rlchain.training.self_play import FrozenPolicy
from tests.conftest import CONFIGS
from tests.unit.test_self_play import keep_self_play

pytestmark = pytest.mark.slow


class KeepPolicy(Callback):
    """Keeps the final policy (deterministic)."""

    def on_train_end(self, ctx, result):
        self.policy = FrozenPolicy(ctx.model, deterministic=True)


@pytest.mark.timeout(180)  # two learning tests share the 2 cores (pytest -n 2)
def test_self_play_beats_random_and_heuristic(tmp_path, monkeypatch):
    keep, kept = KeepPolicy(), keep_self_play(monkeypatch)
    Runner().load(os.path.join(CONFIGS, "ppo_duel_self_play.yaml"),
                  [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false"]).train(callbacks=[keep])
    assert kept[0].updates >= 3  # the opponent was replaced by the policy itself several times
    # 200 deterministic games each; the heuristic itself beats random 82% of the time, perfect play wins 96%
    assert play_duel(keep.policy, "random", games=200, seed=123) > 0.8
    assert play_duel(keep.policy, "heuristic", games=200, seed=321) > 0.8
