"""The PPO update path: the transposed log_softmax equals torch's, compile_update's config checks."""

import os

import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.models.distributions import SHORT_ROW, Categorical, _log_softmax_last
from tests.conftest import CONFIGS


@pytest.mark.parametrize("n", [1, 2, 3, 6, SHORT_ROW, 18])
def test_log_softmax_last_matches_torch_values_and_grads(n):
    torch.manual_seed(n)
    logits = (3 * torch.randn(777, n)).requires_grad_()
    reference = logits.detach().clone().requires_grad_()
    with torch.no_grad():  # the act step: the transposed form, the same values bit for bit
        assert torch.equal(_log_softmax_last(logits), torch.log_softmax(reference, -1))
    out, want = _log_softmax_last(logits), torch.log_softmax(reference, -1)
    assert torch.equal(out, want)
    weights = torch.randn(777, n)
    (out * weights).sum().backward()
    (want * weights).sum().backward()
    # with a gradient torch's own call: the update's gradients are torch's, bit for bit
    assert torch.equal(logits.grad, reference.grad)


def test_categorical_terms_match_torch_distributions():
    torch.manual_seed(0)
    dist = Categorical(4)
    old, new = torch.randn(500, 4), torch.randn(500, 4)
    actions = torch.randint(0, 4, (500,))
    log_prob, entropy = dist.log_prob_and_entropy(new, actions)
    ref_old = torch.distributions.Categorical(logits=old)
    ref_new = torch.distributions.Categorical(logits=new)
    torch.testing.assert_close(log_prob, ref_new.log_prob(actions))
    torch.testing.assert_close(entropy, ref_new.entropy())
    torch.testing.assert_close(dist.kl(old, new), torch.distributions.kl_divergence(ref_old, ref_new))


def _overrides(tmp_path, *extra):
    return [f"params.config.train_dir={tmp_path}", "params.config.max_epochs=1", "params.config.print_stats=false",
            *extra]


def test_compile_update_refuses_an_rnn_network(tmp_path):
    path = os.path.join(CONFIGS, "ppo_cartpole_masked_velocity_rnn.yaml")
    runner = Runner().load(path, _overrides(tmp_path, "params.config.compile_update=True"))
    with pytest.raises(ConfigError, match=r"params\.config\.compile_update: False for an RNN network"):
        runner.train()


def test_compile_update_must_be_a_bool(tmp_path):
    path = os.path.join(CONFIGS, "ppo_torch_cartpole.yaml")
    with pytest.raises(ConfigError, match="compile_update"):
        Runner().load(path, _overrides(tmp_path, "params.config.compile_update=sometimes"))
