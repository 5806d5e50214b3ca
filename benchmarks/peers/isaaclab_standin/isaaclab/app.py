"""``AppLauncher`` without a simulator: parses Isaac Lab's launcher flags; the app runs a fixed number of
play steps (``STANDIN_PLAY_STEPS``, default 200)."""

import argparse
import os


class _App:
    def __init__(self) -> None:
        self.steps = int(os.environ.get("STANDIN_PLAY_STEPS", "200"))

    def is_running(self) -> bool:
        self.steps -= 1
        return self.steps >= 0

    def close(self) -> None:
        pass


class AppLauncher:
    def __init__(self, args: argparse.Namespace | None = None, **kwargs) -> None:
        self.app = _App()
        self.local_rank = int(os.environ.get("LOCAL_RANK", "0"))
        self.global_rank = int(os.environ.get("RANK", "0"))

    @staticmethod
    def add_app_launcher_args(parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--headless", action="store_true", default=False)
        parser.add_argument("--device", type=str, default="cpu")
        parser.add_argument("--enable_cameras", action="store_true", default=False)
        parser.add_argument("--livestream", type=int, default=0)
