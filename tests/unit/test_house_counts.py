"""The package-size counter (benchmarks/studies/house_counts.py) on small sources."""

import ast

from benchmarks.studies.house_counts import code_lines, forwarding_defs, public_names

SOURCE = '''"""Module docstring,
two lines."""

import os  # a comment

LIMIT = 3
"""An attribute docstring."""
_PRIVATE = 1


class Loop:
    """A class."""

    @property
    def epoch(self):
        """Forwards."""
        return self.ctx.epoch

    @epoch.setter
    def epoch(self, value):
        self.ctx.epoch = value

    def close(self):
        self.env.close()

    def save(self, kind):
        return self.checkpoints.write(kind)

    def path(self):
        return os.path.join("a", "b")


def _helper(x):
    # only a comment
    return x
'''


def test_code_lines_skip_docstrings_comments_and_blanks():
    tree = ast.parse(SOURCE)
    # import, LIMIT, _PRIVATE, class, @property, def epoch, return, @setter, def, assign, def close, call,
    # def save, return, def path, return, def _helper, return
    assert code_lines(SOURCE, tree) == 18


def test_public_names_count_defs_and_constants_apart():
    assert public_names(ast.parse(SOURCE)) == (1, 1)


def test_forwarding_defs_count_a_property_once_and_not_renames_or_module_calls():
    assert forwarding_defs(ast.parse(SOURCE)) == 2  # epoch (getter + setter) and close
