"""benchmarks/push_cube_eval.py: the planar cube-to-target distance recovered from the env's reward term."""

import importlib.util
import os

import numpy as np

from tests.conftest import ROOT


def load_script():
    path = os.path.join(ROOT, "benchmarks", "push_cube_eval.py")
    spec = importlib.util.spec_from_file_location("push_cube_eval", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_distance_inverts_the_reciprocal_tolerance_at_any_box_target_scale():
    script = load_script()
    d = np.array([0.0, 0.005, 0.03, 0.0796, 0.2])
    tol = np.where(d <= 0.005, 1.0, 1.0 / (1.0 + 9.0 * (d - 0.005) / 0.4))  # dm_control tolerance, 0.1 at the margin
    for scale in (8.0, 20.0):
        got = script.box_target_distance(scale * tol, scale)
        np.testing.assert_allclose(got, np.where(d <= 0.005, 0.0, d), atol=1e-12)
    # a term of 7.9 is 0.073 m when box_target_scale is 20, but 0.006 m if read with the default 8
    assert abs(script.box_target_distance(np.array([7.9]), 20.0)[0] - 0.073) < 1e-3
