"""``gym_space_from_dict`` reads a file's arrays as bounded data: a zlib stream never inflates past the space's
declared size (a crafted one could expand to GBs), each refusal one line naming the key."""

import base64
import io
import zlib

import gymnasium as gym
import numpy as np
import pytest

from rlchain.rllib.utils import serialization
from rlchain.rllib.utils.serialization import gym_space_from_dict, gym_space_to_dict


def _text(array=None, raw=None):
    if raw is None:
        buf = io.BytesIO()
        np.save(buf, array, allow_pickle=False)
        raw = buf.getvalue()
    return base64.b64encode(zlib.compress(raw)).decode("ascii")


def _one_line(err):
    assert "\n" not in str(err.value)
    return str(err.value)


def test_spaces_round_trip():
    space = gym.spaces.Dict({"obs": gym.spaces.Box(-1.0, 2.0, (3, 2), np.float32),
                             "mask": gym.spaces.MultiDiscrete([3, 4]),
                             "t": gym.spaces.Tuple([gym.spaces.Discrete(5, start=1), gym.spaces.MultiBinary(3)])})
    assert gym_space_from_dict(gym_space_to_dict(space)) == space


def test_a_bomb_is_refused_at_the_declared_size(monkeypatch):
    d = gym_space_to_dict(gym.spaces.Box(-1.0, 1.0, (4,), np.float32))
    d["high"] = _text(np.zeros(4_000_000, np.float32))  # 16 MB inflated from ~16 kB, for a space of 4 floats
    inflated = []
    real = zlib.decompressobj

    class Spy:
        def __init__(self):
            self.inner = real()

        def decompress(self, data, max_length=0):
            out = self.inner.decompress(data, max_length)
            inflated.append(len(out))
            return out

        def __getattr__(self, name):
            return getattr(self.inner, name)

    monkeypatch.setattr(serialization.zlib, "decompressobj", Spy)
    with pytest.raises(ValueError, match="gym_space_from_dict: high: the array inflates past"):
        gym_space_from_dict(d)
    assert max(inflated) <= 16 + serialization.NPY_HEADER_BYTES + 1  # stopped at the declared size


def test_nested_key_is_named():
    d = gym_space_to_dict(gym.spaces.Dict({"obs": gym.spaces.Box(0, 1, (2,), np.float32)}))
    d["spaces"]["obs"]["low"] = _text(np.zeros(1000, np.float32))
    with pytest.raises(ValueError, match="gym_space_from_dict: spaces.obs.low: ") as err:
        gym_space_from_dict(d)
    _one_line(err)


def test_a_header_claiming_more_than_declared_is_refused_before_reading():
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f4", "fortran_order": False, "shape": (10**12,)})
    d = gym_space_to_dict(gym.spaces.Box(0, 1, (2,), np.float32))
    d["low"] = _text(raw=header.getvalue() + b"\x00" * 8)
    with pytest.raises(ValueError, match="low: the stored array \\(1000000000000,\\) of float32 is larger"):
        gym_space_from_dict(d)


def test_declared_shape_and_unshaped_arrays_are_capped(monkeypatch):
    monkeypatch.setattr(serialization, "MAX_ARRAY_BYTES", 1024)
    d = gym_space_to_dict(gym.spaces.Box(0, 1, (2,), np.float32))
    d["shape"] = [1000, 1000]
    with pytest.raises(ValueError, match="low: the declared shape \\(1000, 1000\\) of float32 takes 4000000 bytes"):
        gym_space_from_dict(d)
    md = gym_space_to_dict(gym.spaces.MultiDiscrete([2, 3]))
    md["nvec"] = _text(np.ones(10_000, np.int64))
    with pytest.raises(ValueError, match="gym_space_from_dict: nvec: the array inflates past"):
        gym_space_from_dict(md)


@pytest.mark.parametrize("value,words", [(5, "nvec: expected base64 text"),
                                         ("!!!", "nvec: the compressed array is cut short"),
                                         (base64.b64encode(b"plain").decode(), "nvec: not zlib-compressed")])
def test_bad_text_is_one_line(value, words):
    md = gym_space_to_dict(gym.spaces.MultiDiscrete([2, 3]))
    md["nvec"] = value
    with pytest.raises(ValueError, match=words) as err:
        gym_space_from_dict(md)
    _one_line(err)


def test_pickled_arrays_stay_refused():
    buf = io.BytesIO()
    np.save(buf, np.array([object()], dtype=object), allow_pickle=True)
    md = gym_space_to_dict(gym.spaces.MultiDiscrete([2, 3]))
    md["nvec"] = _text(raw=buf.getvalue())
    with pytest.raises(ValueError, match="nvec: .*pickle"):
        gym_space_from_dict(md)
