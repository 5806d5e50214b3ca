"""A callback that crashes a Ray Tune trial once (tests/smoke/test_tune_ray.py): Tune must restart the
trial from its last checkpoint (FailureConfig). The marker file in the search's train_dir makes it
crash only the first time, across the restarted actor; it is created exclusively (mode "x"), so when two
concurrent trials reach the epoch together only one of them crashes."""

import os

from rlchain.training.events import Callback

CRASH_AT = 5


class CrashOnce(Callback):
    def on_epoch_end(self, ctx, stats, episodes):
        marker = os.path.join(ctx.params.config.train_dir, "crashed_once")
        if ctx.state.epoch != CRASH_AT:
            return
        try:
            with open(marker, "x", encoding="utf-8") as fh:  # atomic: the first trial here wins
                fh.write(f"crashed at epoch {ctx.state.epoch}\n")
        except FileExistsError:
            return
        raise RuntimeError("deliberate crash (test)")
