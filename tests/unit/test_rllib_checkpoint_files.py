"""The face's checkpoint arguments (rlchain/rllib/checkpoint_files.py): a folder path, Ray Tune's ``Checkpoint``
or what ``algo.save()`` returned (RLlib's ``algo.restore(algo.save())``) name the same folder."""

from types import SimpleNamespace

import pytest

from rlchain.rllib.checkpoint_files import CHECKPOINT_FILE, checkpoint_file, checkpoint_path
from rlchain.runs.checkpoint import CheckpointError


def test_a_path_a_tune_checkpoint_and_saves_result_name_the_folder(tmp_path):
    (tmp_path / CHECKPOINT_FILE).write_bytes(b"")
    saved = SimpleNamespace(checkpoint=SimpleNamespace(path=str(tmp_path)))  # save()'s result
    for arg in (tmp_path, str(tmp_path), SimpleNamespace(path=tmp_path), saved):
        assert checkpoint_path(arg) == str(tmp_path)
        assert checkpoint_file(arg) == str(tmp_path / CHECKPOINT_FILE)


def test_anything_else_is_still_one_line(tmp_path):
    with pytest.raises(CheckpointError, match="no such checkpoint folder"):
        checkpoint_file(SimpleNamespace(checkpoint=SimpleNamespace(path=str(tmp_path / "gone"))))
    with pytest.raises(TypeError):
        checkpoint_path(SimpleNamespace(checkpoint=None))
