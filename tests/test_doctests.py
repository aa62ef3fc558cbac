"""The documented examples of the analytical side run and print what their docstrings say."""

import doctest
import importlib

import pytest

MODULES = [
    "magsoft_env.spec.material",
    "magsoft_env.spec.field",
    "magsoft_env.spec.beam",
    "magsoft_env.spec.profiles",
    "magsoft_env.theory.solver",
    "magsoft_env.spec.drive",
    "magsoft_env.units",
    "magsoft_env.threads",
    "magsoft_env.cases.statics",
    "magsoft_env.cases.expressions",
    "magsoft_env.cases.gaits",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0
    assert result.attempted > 0
