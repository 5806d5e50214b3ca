"""A Ray actor holding one trial's trainable as Tune builds it (``tune.with_parameters``), driven step by
step outside Tune's scheduler (tests/smoke/test_tune_ray.py: a restarted trial continues bit-identically).
Its Trainable log folder goes under the test's tmp folder, not ~/ray_results."""

import os

import ray


@ray.remote(num_cpus=1)
class Trial:
    def __init__(self, setup, logdirs):
        from ray import tune
        from ray.tune.trainable import trainable as tune_trainable

        from rlchain.tuning.trainable import RlchainTrainable

        tune_trainable.DEFAULT_STORAGE_PATH = logdirs
        self.trainable = tune.with_parameters(RlchainTrainable, setup=setup)(config={})

    def step(self):
        return self.trainable.step()

    def save(self, checkpoint_dir):
        os.makedirs(checkpoint_dir, exist_ok=True)
        self.trainable.save_checkpoint(checkpoint_dir)

    def load(self, checkpoint_dir):
        self.trainable.load_checkpoint(checkpoint_dir)

    def stop(self):
        self.trainable.stop()
