"""masked_vtrace: V-trace over the active steps of multi-agent rows (skipped, never padded)."""

import torch

from rlchain.algos.core.vtrace import vtrace
from rlchain.algos.multi_policy.masked_vtrace import masked_vtrace

GAMMA = 0.9


def _inputs(t_len: int, n: int, seed: int = 0):
    g = torch.Generator().manual_seed(seed)
    rand = lambda *shape: torch.randn(*shape, generator=g)  # noqa: E731
    return (rand(t_len, n) * 0.5, rand(t_len, n, 1), rand(t_len, n, 1), rand(t_len, n, 1), rand(n, 1))


def test_every_step_active_is_vtrace():
    log_rhos, rewards, values, final_values, last = _inputs(6, 3)
    terminated = torch.zeros(6, 3, dtype=torch.bool)
    truncated = torch.zeros(6, 3, dtype=torch.bool)
    terminated[2, 0], truncated[3, 1] = True, True
    dones = terminated | truncated
    next_values = torch.cat([values[1:], last[None]])
    next_values[dones] = final_values[dones]
    want = vtrace(log_rhos, rewards, values, next_values, terminated, dones, GAMMA, 1.0, 1.0)
    got = masked_vtrace(log_rhos, rewards, values, final_values, last, torch.ones(6, 3, dtype=torch.bool),
                        terminated, dones, GAMMA, 1.0, 1.0)
    for field in ("vs", "advantages", "pg_advantages"):
        torch.testing.assert_close(getattr(got, field), getattr(want, field))


def _compressed(active, log_rhos, rewards, values, final_values, last, terminated, dones):
    """One row's active steps as a plain fragment: rewards summed up to the next active step, an end at an
    inactive step moved onto the active step before it."""
    steps = active.nonzero().squeeze(-1).tolist()
    r, nv, term, done = [], [], [], []
    for k, s in enumerate(steps):
        stop = steps[k + 1] if k + 1 < len(steps) else active.shape[0]
        total, ended = 0.0, None
        for u in range(s, stop):
            total += float(rewards[u])
            if dones[u]:
                ended = u
                break
        r.append(total)
        if ended is not None:
            nv.append(0.0 if terminated[ended] else float(final_values[ended]))
            term.append(bool(terminated[ended]))
            done.append(True)
        else:
            nv.append(float(values[stop]) if stop < active.shape[0] else float(last))
            term.append(False)
            done.append(False)
    col = lambda x: torch.tensor(x).reshape(-1, 1)  # noqa: E731
    return vtrace(log_rhos[steps].reshape(-1, 1), col(r), values[steps].reshape(-1, 1), col(nv),
                  col(term).bool(), col(done).bool(), GAMMA, 1.0, 1.0), steps


def test_inactive_steps_are_skipped_with_their_rewards_and_ends():
    t_len = 8
    log_rhos, rewards, values, final_values, last = _inputs(t_len, 1, seed=1)
    active = torch.tensor([1, 0, 1, 1, 0, 0, 1, 0], dtype=torch.bool).reshape(t_len, 1)
    terminated = torch.zeros(t_len, 1, dtype=torch.bool)
    truncated = torch.zeros(t_len, 1, dtype=torch.bool)
    truncated[4, 0] = True  # an end while the agent waits: the chain of step 3 ends there
    dones = terminated | truncated
    got = masked_vtrace(log_rhos, rewards, values, final_values, last, active, terminated, dones, GAMMA)
    want, steps = _compressed(active[:, 0], log_rhos[:, 0], rewards[:, 0, 0], values[:, 0, 0],
                              final_values[:, 0, 0], last[0, 0], terminated[:, 0], dones[:, 0])
    torch.testing.assert_close(got.vs[steps, 0], want.vs.reshape(-1, 1))
    torch.testing.assert_close(got.advantages[steps, 0], want.advantages.reshape(-1, 1))
    torch.testing.assert_close(got.pg_advantages[steps, 0], want.pg_advantages.reshape(-1, 1))
    idle = ~active[:, 0]
    assert not got.vs[idle].any() and not got.advantages[idle].any() and not got.pg_advantages[idle].any()
