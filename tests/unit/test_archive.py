"""Bounded reading of SB3 archives (rlchain/runs/archive.py, rlchain/sb3/zip_format.py): a member that inflates to
10.5 GiB from an 11 MB file is refused from its declared size before anything is inflated, one that inflates past
what it declares stops there, and malformed JSON fields are one line naming the file and the key. The archives are
crafted by tests/crafted_archives.py without ever holding their claimed size."""

import json
import os
import resource
import zipfile

import pytest

import rlchain
from rlchain.runs import archive
from rlchain.runs import checkpoint as ckpt
from rlchain.sb3.zip_format import read_sb3_archive
from tests.crafted_archives import bomb, members_of, stored, write_zip

DATA = os.path.join(os.path.dirname(__file__), os.pardir, "data", "sb3")
PPO_ZIP, SAC_ZIP = os.path.join(DATA, "ppo_cartpole.zip"), os.path.join(DATA, "sac_pendulum.zip")
BIG = int(10.5 * 2**30)


def rebuilt(tmp_path, src, **replace):
    """``src`` written again at ``tmp_path/crafted.zip`` with members replaced (name -> member tuple)."""
    members = [replace.get(m[0].replace(".", "_"), m) for m in members_of(src)]
    return write_zip(tmp_path / "crafted.zip", members)


def with_data(tmp_path, src, change):
    data = json.loads(zipfile.ZipFile(src).read("data"))
    change(data)
    return rebuilt(tmp_path, src, data=stored("data", json.dumps(data).encode()))


def one_line(exc_info, path, *parts):
    text = str(exc_info.value)
    assert text.startswith(f"{path}: ") and "\n" not in text, text
    for part in parts:
        assert part in text, text
    return text


def peak_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


@pytest.mark.parametrize(("src", "member", "cls"), [(PPO_ZIP, "data", "PPO"), (PPO_ZIP, "policy.pth", "PPO"),
                                                   (SAC_ZIP, "pytorch_variables.pth", "SAC")])
def test_a_zip_bomb_member_is_refused_before_it_inflates(tmp_path, src, member, cls):
    path = rebuilt(tmp_path, src, **{member.replace(".", "_"): bomb(member, BIG)})
    assert os.path.getsize(path) < 12 * 2**20
    before = peak_mib()
    with pytest.raises(ckpt.CheckpointError) as exc:
        getattr(rlchain, cls).load(path)
    one_line(exc, path, f"'{member}' declares 10.5 GiB uncompressed", "far above any real model")
    assert peak_mib() - before < 300  # nothing of the 10.5 GiB was inflated


def test_a_member_inflating_past_its_declared_size_stops_there(tmp_path):
    path = rebuilt(tmp_path, PPO_ZIP, policy_pth=bomb("policy.pth", 256 * 2**20, declared=1000))
    before = peak_mib()
    with pytest.raises(ckpt.CheckpointError) as exc:
        rlchain.PPO.load(path)
    one_line(exc, path, "'policy.pth' cannot be read", "CRC")
    assert peak_mib() - before < 100
    with pytest.raises(archive.ArchiveError, match="'m' declares 64.0 MiB uncompressed; rlchain reads at most 1.0 KiB"):
        archive.read_member(write_zip(tmp_path / "b.zip", [bomb("m", 2**26)]), "m", 1024)


def test_a_symbolic_link_member_is_named_as_one(tmp_path):
    path = str(tmp_path / "link.zip")
    with zipfile.ZipFile(PPO_ZIP) as src, zipfile.ZipFile(path, "w") as dst:
        for name in src.namelist():
            if name == "policy.pth":
                info = zipfile.ZipInfo(name)
                info.create_system, info.external_attr = 3, 0o120777 << 16
                dst.writestr(info, "/etc/passwd")
            else:
                dst.writestr(name, src.read(name))
    with pytest.raises(ckpt.CheckpointError) as exc:
        rlchain.PPO.load(path)
    one_line(exc, path, "'policy.pth' is a symbolic link inside the archive")


@pytest.mark.parametrize(("data", "message"), [
    (b"[1, 2]", "'data' is a JSON list, not the object SB3 writes"),
    (b"[" * 200_000 + b"]" * 200_000, "'data' nests deeper than 64 levels"),
    (b'{"a":' * 100 + b"1" + b"}" * 100, "'data' nests deeper than 64 levels"),
    (b"\xff\xfe{}", "'data' is not UTF-8 text"),
    (b"{nope", "'data' is not JSON"),
])
def test_malformed_data_is_one_line(tmp_path, data, message):
    path = rebuilt(tmp_path, PPO_ZIP, data=stored("data", data))
    with pytest.raises(ckpt.CheckpointError) as exc:
        rlchain.PPO.load(path)
    one_line(exc, path, message)


@pytest.mark.parametrize(("key", "value", "message"), [
    ("num_timesteps", "abc", "num_timesteps: expected an integer"),
    ("num_timesteps", -1, "num_timesteps: expected an integer"),
    ("n_envs", [1], "n_envs: expected an integer in 1 .. 65536, got '[1]' (list)"),
    ("n_envs", 10**9, "n_envs: expected an integer"),
    ("n_envs", True, "n_envs: expected an integer"),
    ("seed", 2**70, "seed: expected an integer"),
    ("seed", "7", "seed: expected an integer"),
    ("learning_rate", "abc", "learning_rate: expected a number, got 'abc'"),
    ("n_steps", float("inf"), "n_steps: expected a number, got 'inf'"),
])
def test_bad_fields_name_the_file_and_the_key(tmp_path, key, value, message):
    path = with_data(tmp_path, PPO_ZIP, lambda data: data.update({key: value}))
    with pytest.raises(ckpt.CheckpointError) as exc:
        rlchain.PPO.load(path)
    one_line(exc, path, message)


@pytest.mark.parametrize(("space", "message"), [
    ({"_shape": [100000, 100000], "low": "-1.0", "high": "1.0"}, "has 10000000000 elements"),
    ({"_shape": [2**40], "low": "-1.0", "high": "1.0"}, "elements; rlchain reads spaces of at most 16777216"),
    ({"_shape": [-4]}, "expected up to 8 sizes >= 0"),
    ({"_shape": "[" + "9" * 5000 + "]"}, "observation_space is malformed"),
    ({"dtype": "V1000000000"}, "expected a number type"),
    ({"_shape": [5], "low": "-1.0", "high": "1.0"}, "takes 4 inputs, the observation_space 5"),
])
def test_space_shapes_are_checked_before_allocation(tmp_path, space, message):
    path = with_data(tmp_path, PPO_ZIP, lambda data: data["observation_space"].update(space))
    before = peak_mib()
    with pytest.raises(ckpt.CheckpointError) as exc:
        read_sb3_archive(path, "ppo")
    one_line(exc, path, message)
    assert peak_mib() - before < 100


def test_sac_ent_coef_auto_and_real_archives_still_read():
    assert read_sb3_archive(SAC_ZIP, "sac").hyperparameters["ent_coef"] == "auto"
    assert read_sb3_archive(PPO_ZIP, "ppo").n_envs >= 1


def test_rlchains_own_zip_members_are_read_within_bounds(tmp_path):
    from rlchain.sb3.model_zip import MEMBER, saved_system_info

    path = write_zip(tmp_path / "own.zip", [m for m in members_of(PPO_ZIP) if m[0] != "system_info.txt"]
                     + [bomb(MEMBER, BIG), bomb("system_info.txt", BIG)])
    with pytest.raises(ckpt.CheckpointError) as exc:
        rlchain.PPO.load(path)
    one_line(exc, path, f"'{MEMBER}' declares 10.5 GiB uncompressed")
    assert "declares 10.5 GiB" in saved_system_info(path)


def test_a_torch_file_whose_records_inflate_far_past_its_size_is_refused_before_torch_reads_it(tmp_path):
    import torch

    real = tmp_path / "real.pth"
    torch.save({"model": {"w": torch.zeros(3)}}, real)
    ckpt.read(str(real))  # an ordinary checkpoint passes the check
    name = zipfile.ZipFile(real).namelist()[0].split("/")[0]
    crafted = write_zip(tmp_path / "bomb.pth", members_of(real) + [bomb(f"{name}/data/9", 2**30)])
    with pytest.raises(ckpt.CheckpointError, match="declare 1.0 GiB uncompressed in a .* file") as info:
        ckpt.read(crafted)
    assert "\n" not in str(info.value)
