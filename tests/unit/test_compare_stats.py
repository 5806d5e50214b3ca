"""IQM and the stratified percentile bootstrap of rlchain/compare/stats.py against hand-computed values."""

import numpy as np
import pytest

from rlchain.compare import stats


def test_iqm_cuts_a_quarter_from_each_end_of_the_flattened_scores():
    assert stats.iqm([1, 2, 3, 4, 5, 6, 7, 8]) == 4.5  # mean of 3, 4, 5, 6
    assert stats.iqm([100, 1, 3, 2]) == 2.5  # the outlier and the minimum cut: mean of 2, 3
    assert stats.iqm([5, 1, 3]) == 3.0  # fewer than 4: nothing cut (floor(0.75) = 0)
    assert stats.iqm([1, 2, 3, 4, 5]) == 3.0  # floor(1.25) = 1 from each end: mean of 2, 3, 4
    assert stats.iqm([[1, 2], [3, 4], [5, 6], [7, 100]]) == 4.5  # runs x tasks, flattened
    with pytest.raises(ValueError, match="non-empty"):
        stats.iqm([])


def test_bootstrap_interval_of_hand_enumerated_resamples():
    # [1, 2, 3]: 27 equally likely resamples; the mean is 1 or 3 in 1/27 = 3.7% of them each (> 2.5%), so
    # the 95% percentile interval is exactly (1, 3)
    assert stats.bootstrap_ci([1, 2, 3], stats.mean, reps=4000, seed=1) == (1.0, 3.0)
    # [0, 10]: means 0, 5, 10 with probabilities 1/4, 1/2, 1/4
    values = stats.bootstrap_replicates([0, 10], stats.mean, reps=8000, seed=2)
    assert set(np.unique(values)) == {0.0, 5.0, 10.0}
    assert np.mean(values == 5.0) == pytest.approx(0.5, abs=0.03)
    assert np.mean(values == 0.0) == pytest.approx(0.25, abs=0.03)
    assert stats.bootstrap_ci([7.0, 7.0, 7.0]) == (7.0, 7.0)


def test_bootstrap_is_stratified_by_task_and_seeded():
    # task A's runs all score 0, task B's all 10: resampling within each task keeps the mean at 5 every time
    # (resampling the 4 scores together would give 0 .. 10)
    values = stats.bootstrap_replicates([[0, 10], [0, 10]], stats.mean, reps=500, seed=3)
    assert np.all(values == 5.0)
    scores = np.arange(12.0).reshape(6, 2) ** 2
    assert stats.bootstrap_ci(scores, seed=4) == stats.bootstrap_ci(scores, seed=4)
    assert not np.array_equal(stats.bootstrap_replicates(scores, seed=4), stats.bootstrap_replicates(scores, seed=5))
    point, low, high = stats.interval_estimate(scores, seed=4)
    assert low <= point <= high and point == stats.iqm(scores)
    with pytest.raises(ValueError, match="confidence"):
        stats.bootstrap_ci([1, 2], confidence=1.5)
