"""rl_games 2.0's config keys: schedule_type per_minibatch (its default's name), max_steps (2.0 trains to the
larger of max_frames and max_steps) and capability_manifest (kept as declared, in every checkpoint's config)."""

import warnings

import pytest

from rlchain.config.compat import translate_config
from rlchain.config.errors import ConfigError


def test_per_minibatch_is_rlchains_legacy_schedule():
    assert translate_config({"schedule_type": "per_minibatch"}, "x")["schedule_type"] == "legacy"
    assert translate_config({"schedule_type": "standard"}, "x")["schedule_type"] == "standard"


@pytest.mark.parametrize(("given", "frames", "warns"), [
    ({"max_frames": 100, "max_steps": 300}, 300, True),
    ({"max_steps": 300}, 300, True),
    ({"max_frames": 500, "max_steps": 300}, 500, False),
])
def test_max_steps_trains_to_the_larger_of_the_two(given, frames, warns):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = translate_config(given, f"src{sorted(given.items())}")  # warn_once: one source per case
    assert out["max_frames"] == frames and "max_steps" not in out
    assert any("larger of max_frames and max_steps" in str(w.message) for w in caught) == warns


def test_max_steps_must_be_a_number():
    with pytest.raises(ConfigError, match="max_steps: expected a number"):
        translate_config({"max_steps": "many"}, "x")


def test_capability_manifest_is_kept_as_declared():
    manifest = {"manifest_version": "0.1", "terrain_classes": ["rigid"]}
    assert translate_config({"capability_manifest": manifest}, "x")["capability_manifest"] == manifest
