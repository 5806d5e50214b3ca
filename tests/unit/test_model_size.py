"""rlchain/models/size.py: a model is counted on the meta device and built only when it fits memory."""

import pytest
import torch

from rlchain.config.errors import ConfigError
from rlchain.models.size import build_within_memory, storage_bytes


def test_a_model_too_large_for_memory_is_one_config_line_before_any_allocation():
    calls = []

    def build():
        calls.append(torch.empty(0).device.type)
        return torch.nn.Sequential(torch.nn.Linear(64, 1_000_000_000_000), torch.nn.Linear(4, 4))

    with pytest.raises(ConfigError, match=r"cfg.yaml: params.network: the model \(65,000,000,000,\d+ parameters\) "
                                          r"needs .* but cpu has .* available") as exc:
        build_within_memory(build, "cpu", "cfg.yaml")
    assert calls == ["meta"] and "\n" not in str(exc.value)  # only the shape-only build ran


def test_a_small_model_is_built_for_real_with_the_same_random_draws():
    torch.manual_seed(3)
    expected = torch.nn.Linear(4, 3).weight.detach().clone()
    torch.manual_seed(3)
    model = build_within_memory(lambda: torch.nn.Linear(4, 3), "cpu", "cfg.yaml")
    assert model.weight.device.type == "cpu" and torch.equal(model.weight, expected)  # meta drew no numbers
    assert storage_bytes(model) == (15, 60)


def test_a_builder_that_cannot_run_on_meta_is_built_unchecked():
    def build():
        layer = torch.nn.Linear(2, 2)
        layer.weight.sum().item()  # reads a value back: impossible on meta
        return layer

    assert isinstance(build_within_memory(build, "cpu", "cfg.yaml"), torch.nn.Linear)
