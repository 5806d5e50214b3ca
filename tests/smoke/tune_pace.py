"""A callback that makes every epoch of a Ray Tune test trial last at least PACE_S seconds
(tests/smoke/test_tune_ray.py). A CartPole epoch takes ~10 ms on an idle machine, so a 30-epoch trial
ends before the next trial's actor has started: asynchronous PBT and ASHA then never see two trials at
once and have nothing to compare. Real trials take minutes; this gives the test's trials that overlap."""

import time

from rlchain.training.events import Callback

PACE_S = 0.15


class Pace(Callback):
    def on_epoch_end(self, ctx, stats, episodes):
        time.sleep(PACE_S)
