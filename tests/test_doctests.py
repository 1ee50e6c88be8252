"""The examples in the docstrings run and print what they show (doctest), module by module.

Every module of the installed package is collected (``robolobes.__main__`` excepted: importing
it runs the command line); a module without examples has nothing to run.
"""

import doctest
import importlib
import pkgutil

import pytest

import robolobes

MODULES = sorted(m.name for m in pkgutil.walk_packages(robolobes.__path__, "robolobes.")
                 if not m.name.endswith("__main__"))


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in finder.find(module, name):  # each example sees a copy of its module's globals
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name} (output above)"
