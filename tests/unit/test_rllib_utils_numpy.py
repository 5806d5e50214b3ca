"""``ray.rllib.utils.numpy`` on the face: the helpers RLlib's inference examples sample actions with."""

import numpy as np
import torch

from rlchain.rllib.utils.numpy import convert_to_numpy, one_hot, softmax


def test_softmax_is_a_distribution_over_the_last_axis_with_a_floor():
    probs = softmax(np.array([[0.0, np.log(3.0)], [1000.0, 0.0]]))
    assert np.allclose(probs.sum(-1), 1.0) and np.allclose(probs[0], [0.25, 0.75])
    assert probs[1, 1] > 0  # the floor keeps every action possible (np.random.choice needs p summing to 1)
    assert np.allclose(softmax(torch.tensor([[2.0, 2.0]])), [[0.5, 0.5]])


def test_convert_to_numpy_maps_nested_tensors_and_reduces_float64():
    out = convert_to_numpy({"a": torch.ones(2, dtype=torch.float64), "b": [torch.tensor(3), "x"]})
    assert out["a"].dtype == np.float32 and out["b"][0] == 3 and out["b"][1] == "x"
    assert convert_to_numpy(np.zeros(1), reduce_type=False).dtype == np.float64


def test_one_hot_rows():
    assert one_hot(np.array([0, 2]), depth=3).tolist() == [[1, 0, 0], [0, 0, 1]]
    assert one_hot(np.array([1])).shape == (1, 2)
