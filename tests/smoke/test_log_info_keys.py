"""log_info_keys reaches the epoch's metrics and TensorBoard tags (env_info/<key>)."""

import pytest

from rlchain import Runner
from rlchain.training.events import Callback

pytestmark = pytest.mark.smoke


def test_envpool_info_key_is_logged_each_epoch(tmp_path):
    pytest.importorskip("envpool")

    class Seen(Callback):
        def __init__(self):
            self.values = []

        def on_epoch_end(self, ctx, stats, episodes):
            self.values.append(stats.get("env_info/elapsed_step"))

    cfg = {"params": {"algo": {"name": "a2c_discrete"}, "model": {"name": "discrete_a2c"},
                      "network": {"name": "actor_critic", "separate": False, "space": {"discrete": {}},
                                  "mlp": {"units": [16], "activation": "relu"}},
                      "config": {"name": "info", "env_name": "envpool", "env_config": {"env_name": "CartPole-v1"},
                                 "num_actors": 4, "horizon_length": 16, "minibatch_size": 32, "mini_epochs": 1,
                                 "max_epochs": 3, "print_stats": False, "train_dir": str(tmp_path),
                                 "log_info_keys": ["elapsed_step"]}}}
    seen = Seen()
    Runner().load(cfg).train(callbacks=[seen])
    assert len(seen.values) == 3 and all(v is not None and v > 0 for v in seen.values)
    assert seen.values[0] < 9  # the first 16 steps of CartPole episodes: elapsed steps ~1-8 on average
