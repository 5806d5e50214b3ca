"""Mutation check: does the test suite catch deliberate one-line bugs in the learning math and the plumbing?

Each mutant replaces one line of rlchain (an exact text, found exactly once in its file) in a temporary copy
of the tree, then runs the fast-tier tests named for it in that copy; a mutant no fast test catches runs the
learning tests named for it (``--learning``). The working tree is never written: the copy is made once, each
mutant is applied to it and undone (try/finally) before the next.

    python tests/tools/mutants.py                      # this tree, fast tiers only
    python tests/tools/mutants.py --tree /path/to/old  # another checkout (the same mutants, its own tests)
    python tests/tools/mutants.py --learning           # a missed mutant also runs its learning tests
    python tests/tools/mutants.py --only gae_lambda    # one mutant

It first runs every named fast test unmutated: a test that fails there would "catch" every mutant, so the
check stops. Prints a markdown table (docs/layout.md keeps the last one) and exits 1 when a mutant is missed.
One torch thread per test run (OMP_NUM_THREADS=1, as the learning tier).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@dataclasses.dataclass(frozen=True)
class Mutant:
    name: str
    what: str  # the bug, in words
    path: str  # the file, relative to the tree's root
    old: str  # the exact text replaced (must occur once)
    new: str
    tests: tuple[str, ...]  # fast-tier test files / ids that should catch it
    learning: tuple[str, ...] = ()  # the learning tests that should, if no fast test does


LOSSES = "rlchain/algos/core/losses.py"
RETURNS = "rlchain/algos/core/returns.py"
PPO_CARTPOLE = ("tests/learning/test_learning.py::test_ppo_cartpole_reaches_475",)

MUTANTS = (
    Mutant("advantage_sign", "the surrogate ascends -A (policy pushed away from good actions)", LOSSES,
           "return torch.max(-advantages * ratio, -advantages * clipped)",
           "return torch.max(advantages * ratio, advantages * clipped)",
           ("tests/unit/test_losses.py",), PPO_CARTPOLE),
    Mutant("gae_lambda", "GAE drops lambda (the advantage sums undiscounted-by-lambda TD errors)", RETURNS,
           "carry = gamma * lam * not_done",
           "carry = gamma * not_done",
           ("tests/unit/test_returns.py",), PPO_CARTPOLE),
    Mutant("ppo_clip", "the ratio is clipped to 1 +- 2 e_clip", LOSSES,
           "clipped = clamp(ratio, 1.0 - e_clip, 1.0 + e_clip)",
           "clipped = clamp(ratio, 1.0 - 2 * e_clip, 1.0 + 2 * e_clip)",
           ("tests/unit/test_losses.py",), PPO_CARTPOLE),
    Mutant("value_target", "the critic's target is the advantage, not advantage + value", RETURNS,
           "return advantages, advantages + values",
           "return advantages, advantages",
           ("tests/unit/test_returns.py",), PPO_CARTPOLE),
    Mutant("value_clipping", "clipped value loss takes the min of the two errors, not the max", LOSSES,
           "loss = torch.max(loss, (clipped - returns).square())",
           "loss = torch.min(loss, (clipped - returns).square())",
           ("tests/unit/test_losses.py",), PPO_CARTPOLE),
    Mutant("adaptive_kl", "the KL the adaptive lr follows is the new policy's to itself (always 0)",
           "rlchain/algos/ppo/loss.py",
           "kl = kl.detach() if penalty else mean(dist.kl(reference, current))",
           "kl = kl.detach() if penalty else mean(dist.kl(current, current))",
           ("tests/unit/test_ppo_kl.py", "tests/unit/test_ppo_parts.py"), PPO_CARTPOLE),
    Mutant("rnn_reset", "RNN states are carried across a finished episode (no reset on done)",
           "rlchain/networks/rnn.py",
           "return _mask(tuple(states), (~dones.bool()).to(states[0].dtype).view(-1, 1))",
           "return tuple(states)",
           ("tests/unit/test_rnn.py", "tests/unit/test_collector.py"),
           ("tests/learning/test_rnn_env_learning.py::test_rnn_remembers_the_goal",)),
    Mutant("obs_normalizer_update", "the running mean weights the batch by the old count",
           "rlchain/models/normalization.py",
           "mean += delta * n / total",
           "mean += delta * self.count / total",
           ("tests/unit/test_normalization.py", "tests/unit/test_running_mean_std.py"),
           ("tests/learning/test_learning.py::test_ppo_pendulum_reaches_minus_250",)),
    Mutant("checkpoint_optimizer", "a restored checkpoint keeps a fresh optimizer (Adam moments lost)",
           "rlchain/algos/ppo/optimizer.py",
           'self.optimizer.load_state_dict(state["optimizer"])',
           "self.optimizer.state_dict()",
           ("tests/unit/test_resume_weights.py", "tests/smoke/test_exact_resume.py")),
    Mutant("resume_rng", "resume does not restore the random generators", "rlchain/training/resume.py",
           'ckpt.set_rng_state(state["rng"])',
           "ckpt.rng_state()",
           ("tests/smoke/test_exact_resume.py",)),
    Mutant("config_default", "gamma's default is 0.9, not 0.99", "rlchain/config/run.py",
           'gamma: float = option(0.99, "discount"',
           'gamma: float = option(0.9, "discount"',
           ("tests/unit/test_config_docs.py", "tests/unit/test_config.py")),
    Mutant("env_truncated", "a gymnasium env's time-out (truncated) does not end the episode",
           "rlchain/envs/backends/gymnasium_env.py",
           "done = terminated | truncated",
           "done = terminated",
           ("tests/unit/test_envs.py",), PPO_CARTPOLE),
    Mutant("policy_mapping", "policy_mapping matches the glob against the agent (arguments swapped)",
           "rlchain/config/multi_agent.py",
           "if fnmatch.fnmatchcase(agent, pattern):",
           "if fnmatch.fnmatchcase(pattern, agent):",
           ("tests/unit/test_pettingzoo.py", "tests/unit/test_multi_agent.py"),
           ("tests/learning/test_pettingzoo_learning.py::"
            "test_simple_tag_predators_trained_with_the_prey_beat_their_starting_selves",)),
    Mutant("sac_target", "SAC's target critic moves by 1 - tau (nearly a copy) instead of tau",
           "rlchain/algos/off_policy/sac_agent.py",
           "torch._foreach_lerp_(self._target_params, self._critic_params, cfg.critic_tau)",
           "torch._foreach_lerp_(self._target_params, self._critic_params, 1.0 - cfg.critic_tau)",
           ("tests/unit/test_sac_dqn.py", "tests/unit/test_sac_target_update.py"),
           ("tests/learning/test_off_policy_learning.py::test_sac_pendulum_reaches_minus_250_within_20k_steps",)),
)

IGNORE = shutil.ignore_patterns(".git", ".venv*", "runs", "__pycache__", ".ci-budget", "*.egg-info", ".pytest_cache",
                                ".ruff_cache", "site")


def pytest(tree: str, tests: list[str], timeout: float) -> tuple[int, float, str]:
    """(exit status, seconds, last output line) of ``pytest -x`` on ``tests`` in ``tree``."""
    env = {**os.environ, "PYTHONPATH": tree, "OMP_NUM_THREADS": "1"}
    start = time.time()
    try:
        done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *tests],
                              cwd=tree, env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return 124, time.time() - start, "timed out"
    lines = [line for line in (done.stdout + done.stderr).splitlines() if line.strip()]
    return done.returncode, time.time() - start, lines[-1] if lines else ""


def present(tree: str, tests: tuple[str, ...]) -> list[str]:
    """The named tests whose file exists in ``tree`` (an older tree may lack a newer test file)."""
    return [t for t in tests if os.path.exists(os.path.join(tree, t.split("::")[0]))]


def mutate(tree: str, mutant: Mutant) -> str:
    """Apply ``mutant`` in ``tree``; returns the file's original text (to restore)."""
    path = os.path.join(tree, mutant.path)
    with open(path) as f:
        text = f.read()
    if text.count(mutant.old) != 1:
        raise SystemExit(f"{mutant.path}: mutant {mutant.name}: expected the text {mutant.old!r} once, "
                         f"found it {text.count(mutant.old)} times")
    with open(path, "w") as f:
        f.write(text.replace(mutant.old, mutant.new))
    return text


def verdict(rc: int) -> str:
    return {0: "missed", 1: "caught", 124: "timed out"}.get(rc, f"caught (exit {rc})")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", default=ROOT, help="the checkout to mutate (copied first; default: this one)")
    parser.add_argument("--learning", action="store_true", help="run a missed mutant's learning tests")
    parser.add_argument("--only", nargs="*", help="mutant names")
    parser.add_argument("--timeout", type=float, default=1800, help="seconds for one pytest run")
    args = parser.parse_args()
    mutants = [m for m in MUTANTS if not args.only or m.name in args.only]
    tree = os.path.abspath(args.tree)
    with tempfile.TemporaryDirectory(prefix="rlchain-mutants-") as tmp:
        copy = os.path.join(tmp, "tree")
        shutil.copytree(tree, copy, ignore=IGNORE, symlinks=True)
        fast = sorted({t for m in mutants for t in present(copy, m.tests)})
        rc, seconds, last = pytest(copy, fast, args.timeout)
        print(f"unmutated: {len(fast)} test files, exit {rc} in {seconds:.0f} s ({last})", flush=True)
        if rc != 0:
            print("the named tests fail on the unmutated tree: fix that first")
            return 2
        rows, missed = [], 0
        for mutant in mutants:
            original = mutate(copy, mutant)
            try:
                tests = present(copy, mutant.tests)
                rc, seconds, last = pytest(copy, tests, args.timeout) if tests else (0, 0.0, "no test file")
                result, learning = verdict(rc), ""
                if rc == 0 and args.learning and mutant.learning:
                    lrc, lseconds, llast = pytest(copy, list(mutant.learning), args.timeout)
                    learning = f"{verdict(lrc)} by {', '.join(mutant.learning)} ({lseconds:.0f} s)"
                    rc = lrc
            finally:
                with open(os.path.join(copy, mutant.path), "w") as f:
                    f.write(original)
            missed += rc == 0
            print(f"{mutant.name}: {result} in {seconds:.0f} s ({last}) {learning}", flush=True)
            rows.append(f"| `{mutant.name}` | {mutant.what} | `{mutant.path}` | "
                        f"{', '.join(f'`{t}`' for t in tests) or '-'} | {result} ({seconds:.0f} s) | "
                        f"{learning or '-'} |")
    print("\n| mutant | the bug | file | fast tests | fast tiers | learning tier |")
    print("|---|---|---|---|---|---|")
    print("\n".join(rows))
    print(f"\n{len(mutants) - missed} of {len(mutants)} caught; tree {tree}")
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
