"""benchmarks/cpu_alternatives.py: the chunked network it times computes the same gradients as autograd,
and a quick run prints a ratio row per chunk size."""

import os
import sys

import pytest
import torch
import torch.nn.functional as F

from tests.conftest import ROOT

sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
cpu_alternatives = pytest.importorskip("cpu_alternatives")


@pytest.mark.parametrize("act", ["relu", "silu", "elu", "tanh"])
def test_chunked_mlp_gradients_match_autograd(act):
    gen = torch.Generator().manual_seed(0)
    layers = [torch.randn(8, 3, generator=gen), torch.randn(8, generator=gen),
              torch.randn(6, 8, generator=gen), torch.randn(6, generator=gen)]
    layers = [t.requires_grad_() for t in layers]
    head_w, head_b = torch.randn(3, 6, generator=gen).requires_grad_(), torch.randn(3, generator=gen).requires_grad_()
    x, target = torch.randn(50, 3, generator=gen), torch.randn(50, 3, generator=gen)
    fn = cpu_alternatives.ACTIVATIONS[act][0]
    params = [head_w, head_b, *layers]

    h = x
    for weight, bias in zip(layers[::2], layers[1::2]):
        h = fn(F.linear(h, weight, bias))
    (F.linear(h, head_w, head_b) - target).square().mean().backward()
    expected = [p.grad.clone() for p in params]
    for p in params:
        p.grad = None
    out = cpu_alternatives.ChunkedMLP.apply(x, act, 16, head_w, head_b, *layers)  # 50 rows: a short last chunk
    (out - target).square().mean().backward()
    for got, want in zip((p.grad for p in params), expected):
        torch.testing.assert_close(got, want, rtol=1e-5, atol=1e-6)


def test_a_quick_run_prints_a_row_per_chunk(capsys):
    cpu_alternatives.main(["--no-compile", "--reps", "1", "--cases", "TorchCartPole-v0", "--envs", "64",
                           "--chunks", "32", "64", "4096"])
    out = capsys.readouterr().out
    assert out.startswith("CPU: ")
    rows = [line for line in out.splitlines() if line.startswith("TorchCartPole-v0 trunk")]
    # 64 envs x 16 steps in 8 minibatches: 128 rows, so chunks of 32 and 64 run and 4096 (not a split) does not
    assert [row.split("chunks of ")[1].split()[0] for row in rows] == ["32", "64"]
    assert all(row.rstrip().endswith("x") for row in rows)


@pytest.mark.parametrize("args, message", [
    (["--reps", "0"], "argument --reps: expected an int >= 1, got '0'"),
    (["--chunks", "64", "x"], "argument --chunks: expected an int >= 1, got 'x'"),
    (["--cases", "CartPole-v1"], "argument --cases: invalid choice: 'CartPole-v1'"),
])
def test_bad_arguments_are_one_line_errors(args, message, capsys):
    with pytest.raises(SystemExit):
        cpu_alternatives.main(["--no-compile", *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert message in err[-1]
