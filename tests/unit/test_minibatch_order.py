"""``minibatch_order``: a fresh shuffle every mini-epoch, or rl_games' fixed env-major blocks."""

import torch

from rlchain.algos.core import storage as storage_module
from rlchain.algos.core.storage import RolloutStorage, env_major_order, pack_rows, unpack_rows

T, N = 4, 3  # horizon 4, 3 envs: time-major flat index t * 3 + n


def _storage():
    storage = RolloutStorage(T, N, (1,), torch.float32, (1,), torch.float32, 2, 1, torch.device("cpu"))
    for t in range(T):
        obs = (t * N + torch.arange(N, dtype=torch.float32)).unsqueeze(-1)  # obs = the flat index
        storage.add(t, obs, torch.zeros(N, 1), torch.zeros(N), torch.zeros(N, 1), torch.zeros(N, 2))
        storage.add_outcome(t, torch.zeros(N, 1), torch.zeros(N, dtype=torch.bool), torch.zeros(N, dtype=torch.bool))
    return storage


def test_env_major_order_lists_each_envs_steps_together():
    assert env_major_order(2, 3).tolist() == [0, 3, 1, 4, 2, 5]
    # env 0's steps 0..3 are flat indices 0, 3, 6, 9; then env 1's: 1, 4, 7, 10
    assert env_major_order(T, N).tolist()[:8] == [0, 3, 6, 9, 1, 4, 7, 10]


def test_fixed_order_gives_the_same_whole_trajectories_every_pass():
    storage = _storage()
    passes = [[b.obs.squeeze(-1).long().tolist() for b in storage.minibatches(8, torch.zeros(T, N), shuffle=False)]
              for _ in range(2)]
    assert passes[0] == passes[1]
    assert passes[0][0] == [0, 3, 6, 9, 1, 4, 7, 10]  # envs 0 and 1, all 4 steps each
    assert passes[0][1] == [2, 5, 8, 11]  # env 2 (the batch of 12 does not divide by 8: a short last one)


def test_fixed_order_batch_index_matches_the_rows():
    storage = _storage()
    for batch in storage.minibatches(4, torch.zeros(T, N), shuffle=False):
        assert batch.index.tolist() == batch.obs.squeeze(-1).long().tolist()


def test_shuffled_order_differs_between_passes_and_covers_every_step():
    storage = _storage()
    torch.manual_seed(0)
    first = [i for b in storage.minibatches(4, torch.zeros(T, N)) for i in b.index.tolist()]
    second = [i for b in storage.minibatches(4, torch.zeros(T, N)) for i in b.index.tolist()]
    assert sorted(first) == sorted(second) == list(range(T * N))
    assert first != second


def test_the_ppo_agent_reads_minibatch_order_and_a_bad_value_is_one_line():
    import copy

    import pytest

    from rlchain.config import ConfigError
    from rlchain.config.load import parse_params
    from tests.conftest import BASE

    raw = copy.deepcopy(BASE)
    raw["params"]["config"]["minibatch_order"] = "fixed"
    assert parse_params(raw, "cfg.yaml").config.minibatch_order == "fixed"
    raw["params"]["config"]["minibatch_order"] = "random"
    with pytest.raises(ConfigError, match=r"cfg.yaml.*params.config.minibatch_order.*auto.*fixed.*shuffle") as info:
        parse_params(raw, "cfg.yaml")
    assert "\n" not in str(info.value)


def test_fixed_order_for_sequences_takes_each_envs_chunks_in_time_order():
    storage = _storage()  # T=4, N=3, sequences of 2 steps: 2 chunks per env
    batches = [b.index.tolist() for b in storage.sequence_minibatches(4, 2, torch.zeros(T, N), shuffle=False)]
    # env 0: steps 0,1 (flat 0, 3) then steps 2,3 (flat 6, 9); then env 1 ...
    assert batches[0] == [0, 3, 6, 9]
    assert batches[1] == [1, 4, 7, 10]
    assert batches == [b.index.tolist() for b in storage.sequence_minibatches(4, 2, torch.zeros(T, N), shuffle=False)]


def test_auto_order_is_fixed_for_continuous_actions_and_shuffled_otherwise():
    from rlchain.algos.ppo.agent import shuffled_minibatches

    assert shuffled_minibatches("auto", continuous=True) is False
    assert shuffled_minibatches("auto", continuous=False) is True
    assert shuffled_minibatches("fixed", continuous=False) is False
    assert shuffled_minibatches("shuffle", continuous=True) is True


def test_a_packed_gather_gives_every_field_bit_for_bit_in_its_dtype():
    size = 64
    flat = {"obs": torch.randn(size, 4), "actions": torch.randint(-2**62, 2**62, (size,)),  # any int64 comes back
            "log_probs": torch.randn(size), "values": torch.randn(size, 2), "params": torch.randn(size, 3),
            "action_masks": torch.rand(size, 5) > 0.5}
    flat["obs"][3, 1] = float("nan")
    flat["actions"][:4] = torch.tensor([0, 1, -1, 2**63 - 1])  # small ones, and bit patterns that read as NaN
    packed, layout = pack_rows(flat)
    assert packed.shape == (size, 4 + 2 + 1 + 2 + 3 + 5)
    idx = torch.randperm(size)[:16]
    out = unpack_rows(packed.index_select(0, idx), layout)
    for key, value in flat.items():
        expected = value.index_select(0, idx)
        assert out[key].dtype == expected.dtype and out[key].shape == expected.shape
        assert torch.equal(out[key].view(torch.uint8), expected.view(torch.uint8)), key  # same bytes, NaN included


def test_shuffled_minibatches_hold_the_same_rows_packed_or_not(monkeypatch):
    packs = []
    monkeypatch.setattr(storage_module, "pack_rows", lambda flat: packs.append(1) or pack_rows(flat))
    storage = _storage()
    advantages = torch.arange(T * N, dtype=torch.float32).reshape(T, N)
    torch.manual_seed(3)
    plain = list(storage.minibatches(4, advantages, shuffle=True))  # under PACKED_MIN_ROWS: field by field
    assert not packs
    monkeypatch.setattr(storage_module, "PACKED_MIN_ROWS", 4)
    torch.manual_seed(3)
    packed = list(storage.minibatches(4, advantages, shuffle=True))
    assert len(packs) == 1  # once per pass
    for a, b in zip(packed, plain, strict=True):
        for field in ("obs", "actions", "log_probs", "values", "returns", "advantages", "params", "index"):
            assert torch.equal(getattr(a, field), getattr(b, field)), field
        assert a.advantages.tolist() == a.obs.squeeze(-1).tolist()  # each row's own advantage


def test_wide_rows_and_other_dtypes_are_gathered_field_by_field():
    assert pack_rows({"obs": torch.zeros(4, 84 * 84, dtype=torch.uint8)}) is None
    assert pack_rows({"obs": torch.zeros(4, 65)}) is None
    assert pack_rows({"obs": torch.zeros(4, 8, dtype=torch.float16)}) is None
