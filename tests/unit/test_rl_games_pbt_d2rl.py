"""rl_games 2.0's names train scripts and network builders import: common.pbt (MultiObserver, PbtCfg,
PbtAlgoObserver) and algos_torch.d2rl (D2RLNet), and the params.pbt section."""

import pytest
import torch
from torch import nn

from rlchain.config.compat import translate_params
from rlchain.config.errors import ConfigError
from rlchain.rl_games.algos_torch.d2rl import D2RLNet
from rlchain.rl_games.common.algo_observer import AlgoObserver
from rlchain.rl_games.common.pbt import MultiObserver, PbtAlgoObserver, PbtCfg


class Counting(AlgoObserver):
    def __init__(self, calls, name):
        self.calls, self.name = calls, name

    def after_print_stats(self, frame, epoch_num, total_time):
        self.calls.append((self.name, frame, epoch_num))


def test_multi_observer_calls_each_in_order():
    calls = []
    observer = MultiObserver([Counting(calls, "a"), Counting(calls, "b")])
    observer.after_print_stats(64, 2, 1.0)
    observer.after_steps()  # the base class's no-op on both
    assert calls == [("a", 64, 2), ("b", 64, 2)]


def test_pbt_observer_disabled_observes_nothing_and_enabled_names_rlchains_pbt():
    assert PbtAlgoObserver({"pbt": {"enabled": False, "num_policies": 4}}, None).cfg.num_policies == 4
    assert PbtAlgoObserver({}, None).cfg.enabled is False
    with pytest.raises(NotImplementedError, match="Ray Tune's PBT"):
        PbtAlgoObserver({"pbt": {"enabled": True, "objective": "scores"}}, None)
    with pytest.raises(ValueError, match="pbt.interval_step: unknown key; did you mean 'interval_steps'"):
        PbtCfg.from_dict({"interval_step": 10})


def test_params_pbt_section():
    assert "pbt" not in translate_params({"pbt": {"enabled": False}, "config": {}}, "t_pbt")
    with pytest.raises(ConfigError, match="params.pbt.enabled: rl_games' re-exec PBT is not offered"):
        translate_params({"pbt": {"enabled": True}}, "t_pbt")


def test_d2rl_net_reads_its_input_at_every_layer():
    net = D2RLNet(3, [8, 5], [nn.ReLU(), nn.Tanh()], norm_func_name="layer_norm")
    assert [layer.in_features for layer in net.linears] == [3, 11]
    assert net(torch.zeros(4, 3)).shape == (4, 5)
    assert {"linears.1.weight", "norm_layers.0.weight"} <= set(net.state_dict())  # rl_games' names
