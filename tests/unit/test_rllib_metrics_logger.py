"""The face's MetricsLogger reduces as RLlib 2.60's: a key keeps the settings of its first log_value, the
default is an EMA carried across results, windows carry over, sums without a window restart each result."""

import math

import pytest

from rlchain.rllib.utils.metrics.metrics_logger import MetricsLogger


def test_a_keys_first_settings_stay_and_its_window_carries_over():
    logger = MetricsLogger()
    logger.log_value("loss", 0.01, reduce="mean", window=2)
    for value in (0.02, 0.03, 0.04, 0.05):
        logger.log_value("loss", value)  # no reduce / window: the key's own
    assert logger.peek("loss") == pytest.approx(0.045)
    assert logger.reduce() == {"loss": pytest.approx(0.045)}
    logger.log_value("loss", 0.07)
    assert logger.reduce()["loss"] == pytest.approx(0.06)  # 0.05 carried over with 0.07


def test_the_default_is_an_ema_of_coefficient_001_carried_across_results():
    logger = MetricsLogger()
    logger.log_value("x", 1.0)
    logger.log_value("x", 2.0)
    assert logger.peek("x") == pytest.approx(1.01)
    assert logger.reduce() == {"x": pytest.approx(1.01)}
    assert logger.reduce() == {"x": pytest.approx(1.01)}  # still reported without new values
    logger.log_value(("a", "b"), 3.0, reduce="ema", ema_coeff=0.5)
    logger.log_value(("a", "b"), 5.0)
    assert logger.peek(("a", "b")) == 4.0


def test_sums_restart_each_result_lifetime_sums_do_not():
    logger = MetricsLogger()
    logger.log_value("n", 50, reduce="sum")
    logger.log_value("n", 25)
    logger.log_value("total", 1, reduce="sum", clear_on_reduce=False)  # RLlib's lifetime_sum
    assert logger.reduce() == {"n": 75.0, "total": 1.0}
    logger.log_value("total", 2)
    assert logger.reduce() == {"total": 3.0}  # n logged nothing: not reported
    logger.log_value("m", 3.0, reduce="max")
    logger.log_value("m", 1.0)
    assert logger.reduce()["m"] == 3.0 and math.isnan(logger._reduce_one("m"))


def test_items_series_timers_and_a_bad_reduce():
    logger = MetricsLogger()
    logger.log_value("img", "frame1", reduce="item")
    logger.log_value("img", "frame2")
    logger.log_value("seen", "a", reduce="item_series", window=2)
    for item in ("b", "c"):
        logger.log_value("seen", item)
    assert logger.peek("img") == "frame2" and logger.peek("seen") == ["b", "c"]
    with logger.log_time("block"):
        pass
    assert 0.0 <= logger.peek("block") < 1.0
    with pytest.raises(ValueError, match="reduce 'median' is not one of"):
        logger.log_value("y", 1.0, reduce="median")
