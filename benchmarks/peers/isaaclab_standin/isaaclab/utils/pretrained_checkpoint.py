"""Isaac Lab downloads published checkpoints from Nucleus; here ``STANDIN_PRETRAINED`` names the file."""

import os


def get_published_pretrained_checkpoint(workflow: str, task_name: str) -> str | None:
    return os.environ.get("STANDIN_PRETRAINED") or None
