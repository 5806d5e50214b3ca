"""parallel/distributed.py: launch validation (no process group) and the syncs on a 1-process gloo group.

The same syncs with two real processes are in tests/smoke/test_distributed.py.
"""

import collections

import pytest
import torch
import torch.distributed as dist

from rlchain.config.errors import ConfigError
from rlchain.models.normalization import RunningMeanStd
from rlchain.parallel import distributed as D

TORCHRUN = {"RANK": "1", "WORLD_SIZE": "2", "LOCAL_RANK": "1", "LOCAL_WORLD_SIZE": "2",
            "MASTER_ADDR": "127.0.0.1", "MASTER_PORT": "29500"}


# ----- launch validation --------------------------------------------------------------------
def test_plain_python_run_is_single_process():
    assert D.read_launch({}, multi_gpu=False) is None


def test_multi_gpu_without_torchrun_fails_with_the_command_to_use():
    with pytest.raises(ConfigError, match=r"cfg.yaml: params.config.multi_gpu: True needs the torchrun launcher: "
                                          r"RANK, WORLD_SIZE, .*start with: torchrun --standalone"):
        D.read_launch({}, multi_gpu=True, source="cfg.yaml")


def test_partial_torchrun_environment_names_what_is_missing():
    env = {"RANK": "0", "WORLD_SIZE": "2"}
    with pytest.raises(ConfigError, match=r"LOCAL_RANK, MASTER_ADDR, MASTER_PORT not set \(only RANK, WORLD_SIZE"):
        D.read_launch(env, multi_gpu=True)


def test_torchrun_with_several_processes_but_multi_gpu_false_is_an_error():
    with pytest.raises(ConfigError, match=r"multi_gpu: launched by torchrun with WORLD_SIZE=2 but multi_gpu is False"):
        D.read_launch(TORCHRUN, multi_gpu=False)


def test_torchrun_with_one_process_and_multi_gpu_false_is_an_ordinary_run():
    env = dict(TORCHRUN, RANK="0", LOCAL_RANK="0", WORLD_SIZE="1", LOCAL_WORLD_SIZE="1")
    assert D.read_launch(env, multi_gpu=False) is None


def test_valid_launch_is_read():
    launch = D.read_launch(TORCHRUN, multi_gpu=True)
    assert launch == D.Launch(rank=1, world_size=2, local_rank=1, local_world_size=2)


@pytest.mark.parametrize("changes, message", [
    ({"RANK": "2"}, r"RANK=2 is not in \[0, WORLD_SIZE=2\)"),
    ({"RANK": "x"}, r"environment variable RANK='x' is not an integer"),
    ({"LOCAL_RANK": "5"}, r"LOCAL_RANK=5 is not in \[0, LOCAL_WORLD_SIZE=2\)"),
])
def test_inconsistent_rank_variables(changes, message):
    with pytest.raises(ConfigError, match=message):
        D.read_launch(dict(TORCHRUN, **changes), multi_gpu=True)


def test_algorithm_without_distributed_support():
    with pytest.raises(ConfigError, match=r"'sac' does not support multi_gpu \(torchrun\) yet"):
        D.read_launch(TORCHRUN, multi_gpu=True, algo_supports=False, algo="sac")
    with pytest.raises(ConfigError, match=r"WORLD_SIZE=2 but 'sac' does not support multi_gpu yet"):
        D.read_launch(TORCHRUN, multi_gpu=False, algo_supports=False, algo="sac")


def test_off_policy_config_rejects_multi_gpu(base_config):
    from rlchain.config.load import parse_params
    cfg = base_config["params"]
    cfg["algo"], cfg["model"] = {"name": "sac"}, {"name": "soft_actor_critic"}
    cfg["network"] = {"name": "soft_actor_critic", "mlp": {"units": [8]}}
    cfg["config"] = {"name": "s", "env_name": "Pendulum-v1", "device": "cpu", "multi_gpu": True}
    with pytest.raises(ConfigError, match=r"params.config.multi_gpu: not implemented in rlchain yet"):
        parse_params(base_config)


def test_backend_follows_the_device():
    assert D.choose_backend("cpu", 1, cuda_count=2) == ("gloo", "cpu")
    assert D.choose_backend("cuda:0", 1, cuda_count=0) == ("gloo", "cpu")  # no CUDA: cpu, as one process does
    assert D.choose_backend("cuda:0", 1, cuda_count=2) == ("nccl", "cuda:1")  # each rank on its LOCAL_RANK GPU
    with pytest.raises(ConfigError, match=r"LOCAL_RANK=2 but this node has 2 GPU\(s\)"):
        D.choose_backend("cuda", 2, cuda_count=2)


def test_config_fingerprint_sees_values_and_seed_not_key_order():
    a = {"params": {"config": {"num_actors": 8, "horizon_length": 16}, "seed": 1}}
    b = {"params": {"seed": 1, "config": {"horizon_length": 16, "num_actors": 8}}}
    assert D.config_fingerprint(a, None) == D.config_fingerprint(b, None)
    c = {"params": {"config": {"num_actors": 9, "horizon_length": 16}, "seed": 1}}
    assert D.config_fingerprint(a, None) != D.config_fingerprint(c, None)
    assert D.config_fingerprint(a, 3) != D.config_fingerprint(a, 4)


def test_first_mismatch():
    assert D.first_mismatch(["a", "a", "a"]) is None
    assert D.first_mismatch(["a", "a", "b", "c"]) == 2


def test_rank_seeds_are_distinct_and_rank0_keeps_the_seed():
    seeds = [D.Distributed(r, 4, r, "gloo", seed=7).rank_seed for r in range(4)]
    assert seeds[0] == 7 and len(set(seeds)) == 4
    assert min(b - a for a, b in zip(seeds, seeds[1:])) > 10_000  # more than any num_actors apart


def test_merge_moments_equals_moments_of_the_union():
    gen = torch.Generator().manual_seed(0)
    parts = [torch.randn(n, 3, generator=gen, dtype=torch.float64) * (i + 1) + i for i, n in enumerate((5, 17, 2))]
    mean, var, count = D.merge_moments(torch.stack([p.mean(0) for p in parts]),
                                       torch.stack([p.var(0, unbiased=False) for p in parts]),
                                       torch.tensor([5.0, 17.0, 2.0], dtype=torch.float64))
    union = torch.cat(parts)
    assert float(count) == 24
    torch.testing.assert_close(mean, union.mean(0), rtol=0, atol=1e-12)
    torch.testing.assert_close(var, union.var(0, unbiased=False), rtol=0, atol=1e-12)


# ----- the syncs on a 1-process gloo group ---------------------------------------------------
@pytest.fixture(scope="module")
def group(tmp_path_factory):
    assert not dist.is_initialized()
    store = tmp_path_factory.mktemp("pg") / "store"
    dist.init_process_group("gloo", init_method=f"file://{store}", rank=0, world_size=1)
    yield
    dist.destroy_process_group()


@pytest.mark.timeout(30)
def test_average_gradients_one_flat_all_reduce(group, monkeypatch):
    a, b, c = (torch.nn.Parameter(torch.zeros(s)) for s in ((2, 3), (4,), (1,)))
    a.grad, b.grad = torch.arange(6.0).reshape(2, 3), torch.ones(4)  # c has no gradient
    calls = []
    real = dist.all_reduce
    monkeypatch.setattr(dist, "all_reduce", lambda t, **kw: calls.append(t.numel()) or real(t, **kw))
    D.average_gradients([a, b, c])
    assert calls == [11]  # one buffer holding every parameter, a missing grad as zeros
    assert torch.equal(a.grad, torch.arange(6.0).reshape(2, 3)) and torch.equal(b.grad, torch.ones(4))
    assert torch.equal(c.grad, torch.zeros(1))


@pytest.mark.timeout(30)
def test_normalizer_built_with_a_communicator_syncs_through_it(group):
    from rlchain.parallel import communicator

    plain = RunningMeanStd((3,))
    pg = D.Distributed(0, 1, 0, "gloo", seed=0)
    pg.world_size = 2  # pretend there is a peer, so the sync path runs (the group has one rank)
    calls = []
    pg.combine_moments = lambda *moments: calls.append(1) or D.combine_moments(*moments)
    with communicator.building_with(pg):
        synced = RunningMeanStd((3,))
    assert synced.comm is pg and plain.comm is communicator.SINGLE
    for i in range(3):
        x = torch.randn(10, 3) + i
        plain.update(x)
        synced.update(x)
    assert calls == [1, 1, 1]
    for name in ("running_mean", "running_var", "count"):
        torch.testing.assert_close(getattr(synced, name), getattr(plain, name), rtol=0, atol=1e-12)


@pytest.mark.timeout(30)
def test_rank_mean_and_episode_stats_on_one_rank(group):
    pg = D.Distributed(0, 1, 0, "gloo", seed=0)
    for kl in (0.1, 0.001, 0.01):
        assert pg.mean(kl) == kl
    tracker = collections.namedtuple("T", "finished_returns finished_lengths finished_successes")(
        [1.0, 3.0], [10, 30], [])
    assert pg.episode_stats(tracker) == {"reward": 2.0, "length": 20.0}
    assert pg.episode_stats(tracker._replace(finished_returns=[], finished_lengths=[])) is None
    # envs that report success: the rate over the games that had a success value
    stats = pg.episode_stats(tracker._replace(finished_successes=[1.0, 0.0, 0.0, 1.0]))
    assert stats == {"reward": 2.0, "length": 20.0, "success": 0.5}


def test_a_failed_collective_becomes_one_line_naming_the_rank():
    """Errors are recognised by type: a failure inside one of the Communicator's collectives is a
    CollectiveError; torch's DistError family from anywhere else becomes one; others stay as they are."""
    from rlchain.errors import DistributedError
    group = D.Distributed(1, 2, 1, "gloo", seed=0)

    def broken(*args):
        raise RuntimeError("Read error: Connection reset by peer")

    with pytest.raises(D.CollectiveError) as err:
        group._collective("gradient all-reduce", broken)
    assert isinstance(err.value, DistributedError) and "\n" not in str(err.value)
    assert str(err.value).startswith("rank 1: a collective with the other ranks failed (gradient all-reduce: "
                                     "Read error: Connection reset")
    assert D.collective_failure(group, err.value) is err.value
    lost = D.collective_failure(group, dist.DistBackendError("NCCL communicator was aborted"))
    assert isinstance(lost, D.CollectiveError) and "DistBackendError: NCCL communicator was aborted" in str(lost)
    assert D.collective_failure(group, RuntimeError("an env bug")) is None  # not a collective
    assert D.collective_failure(None, err.value) is None  # single process: errors stay as they are
    assert D.collective_failure(group, KeyboardInterrupt()) is None
