"""``import rl_games...`` resolved to ``rlchain.rl_games...`` in this process (the drop-in switch).

:func:`install` puts a finder first on ``sys.meta_path`` (:class:`rlchain.faces.ModuleAlias`): a module name
``rl_games`` or ``rl_games.X.Y`` is answered with the module object ``rlchain.rl_games.X.Y`` (one object under both
names, so ``rl_games.common.vecenv.register`` and rlchain's registry are the same). Nothing is written to disk and
no other process sees it: the real rl_games, where installed, is untouched.
"""

from __future__ import annotations

from rlchain.faces import ModuleAlias
from rlchain.rl_games.agents import not_offered_message


class RlGamesAlias(ModuleAlias):
    """Answers ``rl_games.*`` with ``rlchain.rl_games.*``; a name rlchain does not offer
    (:data:`rlchain.rl_games.agents.NOT_OFFERED`) is the one-line ImportError saying what to use."""

    ALIAS = "rl_games"
    TARGET = "rlchain.rl_games"

    def refuse(self, fullname: str) -> None:
        message = not_offered_message(fullname)
        if message is not None:
            raise ImportError(message, name=fullname)


install = RlGamesAlias.install
uninstall = RlGamesAlias.uninstall
target_name = RlGamesAlias.target_name
