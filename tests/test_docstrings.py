"""Every runnable example in the package's docstrings runs and prints what it says."""

import doctest
import importlib
import pkgutil

import pytest

import edmd

MODULES = sorted(m.name for m in pkgutil.walk_packages(edmd.__path__, "edmd.") if not m.name.endswith("__main__"))


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} docstring example(s) failed in {name}"


def test_examples_exist_where_promised():
    with_examples = [n for n in MODULES if doctest.DocTestFinder().find(importlib.import_module(n))
                     and any(t.examples for t in doctest.DocTestFinder().find(importlib.import_module(n)))]
    assert len(with_examples) >= 10
