"""SB3's logger semantics on rlchain: what a callback records is dumped at SB3's log interval without the callback
dumping it (PPO: every ``log_interval`` iterations), figures / images / hparams / text go to TensorBoard, and
``logger.output_formats`` holds SB3's TensorBoardOutputFormat with the run's writer (SB3's tensorboard guide)."""

import glob
import os

import numpy as np
import pytest

import rlchain

pytest.importorskip("stable_baselines3")
from stable_baselines3.common.callbacks import BaseCallback  # noqa: E402
from stable_baselines3.common.logger import Figure, HParam, Image, TensorBoardOutputFormat  # noqa: E402

pytestmark = pytest.mark.smoke


def events(run_dir):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
    found = {"scalars": {}, "images": set(), "text": set()}
    for path in glob.glob(os.path.join(run_dir, "**", "events.out.tfevents.*"), recursive=True):
        acc = EventAccumulator(path, size_guidance={"scalars": 0, "images": 0, "tensors": 0})
        acc.Reload()
        tags = acc.Tags()
        for tag in tags.get("scalars", []):
            found["scalars"].setdefault(tag, []).extend(e.step for e in acc.Scalars(tag))
        found["images"].update(tags.get("images", []))
        found["text"].update(t for t in tags.get("tensors", []))
    return found


class Recorder(BaseCallback):
    def _on_training_start(self):
        self.tb = next(f for f in self.logger.output_formats if isinstance(f, TensorBoardOutputFormat))
        self.logger.record("hparams", HParam({"gamma": self.model.gamma, "lr": self.model.learning_rate},
                                             {"rollout/ep_len_mean": 0}), exclude=("stdout", "log", "json", "csv"))

    def _on_step(self):
        self.logger.record("random_value", float(np.random.random()))
        if self.n_calls == 1:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
            figure = plt.figure()
            figure.add_subplot().plot([1, 2, 3])
            self.logger.record("trajectory/figure", Figure(figure, close=True), exclude=("stdout", "log"))
            self.logger.record("trajectory/image", Image(np.zeros((8, 8, 3), np.uint8), "HWC"))
            self.tb.writer.add_text("direct_access", "this is a value", self.num_timesteps)
        return True


def test_records_dump_at_sb3s_log_interval_with_figures_images_hparams(tmp_path):
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", n_steps=16, batch_size=16, verbose=0,
                        tensorboard_log=str(tmp_path / "runs"))
    model.learn(64, callback=Recorder(), log_interval=2)  # 4 iterations: dumps after the 2nd and the 4th
    found = events(model.run_dir)
    assert sorted(found["scalars"]["random_value"]) == [32, 64]
    assert {"trajectory/figure", "trajectory/image"} <= found["images"]
    assert any("direct_access" in tag for tag in found["text"])
    files = glob.glob(os.path.join(model.run_dir, "**", "events.out.tfevents.*"), recursive=True)
    assert any(b"_hparams_/session_start_info" in open(f, "rb").read() for f in files)  # TensorBoard's HPARAMS
