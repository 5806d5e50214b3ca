"""What issue 37's CPU work tried on tensor-env PPO and did not ship, measured side by side with what ships.

Each line times the shipped way and an alternative on the same inputs in one process, medians of
``--reps`` calls, and prints the ratio shipped / alternative (above 1: the alternative is faster):

- ``trunk``: the update's network forward and backward over one minibatch of the shipped config (torch
  autograd, as the update runs it) against a hand-written autograd function that runs the trunk and heads
  over row chunks small enough to stay in cache and recomputes each chunk's activations in the backward
  pass instead of keeping them (fewer passes over memory, more arithmetic);
- ``act``: the rollout's act step (``model.act``: forward, sample, log-prob, values) eager against
  ``torch.compile(model.act)``;
- ``physics``: a tensor env's ``step`` eager against the same env with its ``_step_physics`` compiled;
- ``gae``: :func:`rlchain.algos.core.returns.gae` (a Python loop over the horizon) eager against compiled,
  at the config's (horizon, envs), with its share of one epoch of the shipped path.

``--no-compile`` leaves out the compiled alternatives (a quick check, as the unit test runs it)::

    python benchmarks/cpu_alternatives.py --envs 4096 --threads 2
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable

import torch
import torch.nn.functional as F

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))

import throughput as tp  # noqa: E402
from curves import cpu_model  # noqa: E402

from rlchain.algos.core.returns import gae  # noqa: E402
from rlchain.models.build import build_env, build_model  # noqa: E402
from rlchain.parallel.memory import tune_malloc  # noqa: E402

CASES = ("TorchCartPole-v0", "TorchPendulum-v0", "TorchReacher8-v0")
ACTIVATIONS = {"relu": (F.relu, lambda g, z, h: torch.ops.aten.threshold_backward(g, h, 0)),
               "silu": (F.silu, lambda g, z, h: torch.ops.aten.silu_backward(g, z)),
               "elu": (F.elu, lambda g, z, h: torch.ops.aten.elu_backward(g, 1.0, 1.0, 1.0, False, z)),
               "tanh": (torch.tanh, lambda g, z, h: torch.ops.aten.tanh_backward(g, h))}


def median_seconds(fn: Callable[[], object], reps: int, warmup: int = 3) -> float:
    """Median wall seconds of ``reps`` calls of ``fn`` after ``warmup`` calls."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(reps):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


class ChunkedMLP(torch.autograd.Function):
    """Dense layers with one activation, then linear heads, over row chunks; backward recomputes each chunk.

    ``forward(x, act, chunk, heads_w, heads_b, w1, b1, w2, b2, ...)`` returns ``x``'s head outputs
    (B, heads_w.shape[0]); gradients go to the weights and biases only (``x`` is an input)."""

    @staticmethod
    def forward(ctx, x, act, chunk, head_w, head_b, *layers):  # noqa: ANN001, ANN205 (autograd's signature)
        fn = ACTIVATIONS[act][0]
        out = x.new_empty(x.shape[0], head_w.shape[0])
        for start in range(0, x.shape[0], chunk):
            h = x[start:start + chunk]
            for weight, bias in zip(layers[::2], layers[1::2]):
                h = fn(torch.addmm(bias, h, weight.t()))
            torch.addmm(head_b, h, head_w.t(), out=out[start:start + chunk])
        ctx.save_for_backward(x, head_w, *layers)
        ctx.act, ctx.chunk = act, chunk
        return out

    @staticmethod
    def backward(ctx, grad):  # noqa: ANN001, ANN205
        x, head_w, *layers = ctx.saved_tensors
        fn, fn_backward = ACTIVATIONS[ctx.act]
        weights, biases = layers[::2], layers[1::2]
        grad = grad.contiguous()
        head_wg, head_bg = torch.zeros_like(head_w), grad.sum(0)
        wg, bg = [torch.zeros_like(w) for w in weights], [torch.zeros_like(b) for b in biases]
        for start in range(0, x.shape[0], ctx.chunk):
            hs, zs = [x[start:start + ctx.chunk]], []
            for weight, bias in zip(weights, biases):
                zs.append(torch.addmm(bias, hs[-1], weight.t()))
                hs.append(fn(zs[-1]))
            g = grad[start:start + ctx.chunk]
            head_wg.addmm_(g.t(), hs[-1])
            gh = g @ head_w
            for i in reversed(range(len(weights))):
                gz = fn_backward(gh, zs[i], hs[i + 1])
                wg[i].addmm_(gz.t(), hs[i])
                bg[i].add_(gz.sum(0))
                if i:
                    gh = gz @ weights[i]
        pairs = [g for pair in zip(wg, bg) for g in pair]
        return None, None, None, head_wg, head_bg, *pairs


def trunk_rows(units: list[int], act: str, obs: int, heads: int, rows: int, reps: int,
               chunks: tuple[int, ...]) -> list[tuple[str, float, float]]:
    """(label, autograd seconds, chunked seconds) of one forward + backward, per chunk size."""
    gen = torch.Generator().manual_seed(0)
    dims = [obs, *units]
    layers = []
    for fan_in, fan_out in zip(dims[:-1], dims[1:]):
        layers += [(torch.randn(fan_out, fan_in, generator=gen) / fan_in ** 0.5).requires_grad_(),
                   torch.zeros(fan_out, requires_grad=True)]
    head_w = (torch.randn(heads, dims[-1], generator=gen) * 0.01).requires_grad_()
    head_b = torch.zeros(heads, requires_grad=True)
    x, target = torch.randn(rows, obs, generator=gen), torch.randn(rows, heads, generator=gen)
    params = [head_w, head_b, *layers]
    fn = ACTIVATIONS[act][0]

    def autograd() -> None:
        h = x
        for weight, bias in zip(layers[::2], layers[1::2]):
            h = fn(F.linear(h, weight, bias))
        (F.linear(h, head_w, head_b) - target).square().mean().backward()

    def chunked(chunk: int) -> Callable[[], None]:
        def run() -> None:
            (ChunkedMLP.apply(x, act, chunk, head_w, head_b, *layers) - target).square().mean().backward()
        return run

    def clear_then(run: Callable[[], None]) -> Callable[[], None]:
        def call() -> None:
            for p in params:
                p.grad = None
            run()
        return call

    base = median_seconds(clear_then(autograd), reps)
    label = f"{rows} x {obs} -> {units} {act}"
    return [(f"{label}, chunks of {chunk}", base, median_seconds(clear_then(chunked(chunk)), reps))
            for chunk in chunks if chunk < rows]


def build_case(env_name: str, envs: int):
    """The shipped config's env, model and params at ``envs`` envs, as throughput.py builds them."""
    backend, env_name, num, config = tp.parse_case(f"torch:{env_name}:{envs}")
    params = tp.case_runner(backend, env_name, num, config, "cpu").params
    env = build_env(params, num, 0)
    model = build_model(params, env, torch.device("cpu"))
    return params, env, model


def network_shape(params, env) -> tuple[list[int], str, int, int, int]:  # noqa: ANN001
    """(units, activation, obs size, head outputs, minibatch rows) of a shipped config's update."""
    mlp = params.network.mlp
    space = env.action_space  # the heads: logits (discrete) or means (continuous, a fixed sigma), and the value
    heads = (int(space.n) if hasattr(space, "n") else int(space.shape[0])) + 1
    return list(mlp.units), str(mlp.activation), int(env.observation_space.shape[0]), heads, \
        int(params.config.minibatch_size)


def positive(spec: str) -> int:
    """An int >= 1 for --envs, --threads, --reps and --chunks (argparse turns the error into one line)."""
    try:
        value = int(spec)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an int >= 1, got '{spec}'")
    return value


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--envs", type=positive, default=4096)
    ap.add_argument("--threads", type=positive, default=2)
    ap.add_argument("--reps", type=positive, default=20)
    ap.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    ap.add_argument("--chunks", nargs="+", type=positive, default=[1024, 2048, 4096])
    ap.add_argument("--no-compile", action="store_true", help="leave out the compiled alternatives")
    args = ap.parse_args(argv)
    tune_malloc("keep")  # as training does
    torch.set_num_threads(args.threads)
    print(f"CPU: {cpu_model()}, {os.cpu_count()} cores, torch {torch.__version__}, {args.threads} threads, "
          f"{args.envs} envs")
    print(f"{'what':<64} {'shipped ms':>11} {'alt ms':>9} {'shipped/alt':>12}")
    for name in args.cases:
        params, env, model = build_case(name, args.envs)
        units, act, obs, heads, rows = network_shape(params, env)
        rows_out = [(f"{name} trunk {label}", a, b)
                    for label, a, b in trunk_rows(units, act, obs, heads, rows, args.reps, tuple(args.chunks))]
        if not args.no_compile:
            rows_out += compiled_rows(name, params, env, model, args.reps)
        for label, shipped, alternative in rows_out:
            print(f"{label:<64} {shipped * 1e3:>11.3f} {alternative * 1e3:>9.3f} {shipped / alternative:>11.2f}x",
                  flush=True)


def compiled_rows(name: str, params, env, model, reps: int) -> list[tuple[str, float, float]]:  # noqa: ANN001
    """The act step, the env step and GAE, eager against compiled (after one compiling call)."""
    obs = env.reset(seed=0)
    model.eval()
    rows = []
    with torch.inference_mode():
        compiled_act = torch.compile(model.act, dynamic=False)
        rows.append((f"{name} act step, compiled", median_seconds(lambda: model.act(obs), reps),
                     median_seconds(lambda: compiled_act(obs), reps)))
        actions = model.dist.to_env(model.act(obs)["actions"])
        eager = median_seconds(lambda: env.step(actions), reps)
        env._step_physics = torch.compile(env._step_physics, dynamic=False)
        rows.append((f"{name} env step, physics compiled", eager, median_seconds(lambda: env.step(actions), reps)))
    cfg = params.config
    shape = (int(cfg.horizon_length), env.num_envs)
    gen = torch.Generator().manual_seed(0)
    rewards, values, next_values = (torch.randn(*shape, *tail, generator=gen) for tail in ((), (1,), (1,)))
    terminated = torch.rand(shape, generator=gen) < 0.01
    dones = terminated | (torch.rand(shape, generator=gen) < 0.01)
    args = (rewards, values, next_values, terminated, dones, 0.99, 0.95)
    compiled_gae = torch.compile(gae, dynamic=False)
    rows.append((f"{name} gae {shape[0]} x {shape[1]}, compiled", median_seconds(lambda: gae(*args), reps),
                 median_seconds(lambda: compiled_gae(*args), reps)))
    return rows


if __name__ == "__main__":
    main()
