"""rlchain/config/text.py: a YAML / JSON file read safely, each bad file one ConfigError line naming it."""

import pytest

from rlchain.config.errors import ConfigError
from rlchain.config.text import MAX_NESTING, depth_of, nesting, read_data


@pytest.mark.parametrize("name, data, words", [
    ("bytes.yaml", bytes(range(256)), "not UTF-8 text (byte 0x80 at offset 128)"),
    ("deep.yaml", b"params: " + b"[" * 5000, "nested 5000 levels deep"),
    ("deep.json", b"[" * 100_000, "nested 100000 levels deep"),
    ("indent.yaml", ("a:\n" + "".join("  " * i + f"k{i}:\n" for i in range(1, 200))).encode(), "nest"),
    ("alias.yaml", b"a: &x [1]\nb: *x\n", "YAML alias *x is not allowed"),
])
def test_a_bad_file_is_one_line(tmp_path, name, data, words):
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(ConfigError) as exc:
        read_data(str(path))
    text = str(exc.value)
    assert text.startswith(str(path)) and words in text and "\n" not in text, text


def test_nesting_counts_brackets_and_depth_counts_containers():
    assert nesting("a: [1, {b: [2]}]") == 3 and nesting("]]][") == 1
    assert depth_of({"a": [1, {"b": [2]}]}) == 4 and depth_of(5) == 0
    deep = []
    for _ in range(MAX_NESTING + 5):
        deep = [deep]
    assert depth_of(deep) > MAX_NESTING  # counted without recursion


def test_a_gym_config_file_is_read_the_same_way(tmp_path):
    from rlchain.config.embodichain_task import resolve_env

    (tmp_path / "gym.json").write_bytes(b"\xff\xfe")
    with pytest.raises(ConfigError, match="not UTF-8 text"):
        resolve_env({"gym_config": str(tmp_path / "gym.json")}, str(tmp_path / "train.json"))
