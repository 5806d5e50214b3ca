"""What tests/smoke/test_docs_commands.py shortens in a docs page's ``python`` block, as it shortens a command line.

A command line gets ``params.config.max_epochs=1`` appended and its ``.learn(N)`` made ``.learn(2048)``; a python
block says the same things in Python, so its ``Runner().load(...)`` gets ``params.config.max_epochs=PY_EPOCHS``
appended where the config trains longer (or without a limit), and an SB3-style ``model.learn(N)`` learns at most
``SHORT_LEARN`` steps (it loads its config through Runner.load, so it also stops at 2 epochs, whichever comes
first). Two epochs, not one: a block's callback that acts every second epoch or evaluation (the VideoCallback
example) still acts once. Everything else in the block runs as written.

Installed in the block's process before it runs: by the docs fork server (``"prelude"`` of a request,
tests/smoke/forkserver.py) or, with ``RLCHAIN_DOCS_FRESH=1``, by running ``python docs_caps.py BLOCK.py``, which
installs the caps and runs the block as ``python BLOCK.py`` would.
"""

from __future__ import annotations

import os
import runpy
import sys

PY_EPOCHS = 2  # a python block's runs train at most this many epochs
SHORT_LEARN = 2048  # steps of an SB3-style learn(N), as test_docs_commands.SHORT_LEARN for a command line


def capped_overrides(max_epochs: int, overrides: list[str] | None) -> list[str] | None:
    """``overrides`` with ``params.config.max_epochs=PY_EPOCHS`` appended where ``max_epochs`` (the loaded
    config's) is longer or unlimited (-1); None where the config already stops within the cap."""
    if 0 <= max_epochs <= PY_EPOCHS:
        return None
    return [*(overrides or []), f"params.config.max_epochs={PY_EPOCHS}"]


def install() -> None:
    """Cap Runner.load's epochs and the SB3-style classes' learn steps in this process."""
    from rlchain.runner import Runner
    from rlchain.sb3.model import BaseModel

    load = Runner.load

    def capped_load(self, config, overrides=None):
        runner = load(self, config, overrides)
        longer = capped_overrides(runner.params.config.max_epochs, overrides)
        return runner if longer is None else load(self, config, longer)

    learn = BaseModel.learn

    def capped_learn(self, total_timesteps, *args, **kwargs):
        return learn(self, min(int(total_timesteps), SHORT_LEARN), *args, **kwargs)

    Runner.load = capped_load
    BaseModel.learn = capped_learn


if __name__ == "__main__":  # python docs_caps.py BLOCK.py: the block as `python BLOCK.py` runs it, capped
    script = sys.argv[1]
    sys.argv = sys.argv[1:]
    sys.path[0] = os.path.dirname(os.path.abspath(script))
    install()
    runpy.run_path(script, run_name="__main__")
