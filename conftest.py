"""pytest: the console and Python examples of README.md and docs/ are tests too (Sybil).

See tests/doc_console.py for how a ```console block is run and compared.
"""

import os
from doctest import ELLIPSIS, NORMALIZE_WHITESPACE

from doc_console import ConsoleParser, make_sandbox, remove_sandbox
from sybil import Sybil
from sybil.parsers.markdown import PythonCodeBlockParser, SkipParser


def _setup(namespace):
    namespace["sandbox"] = make_sandbox()
    namespace["_cwd"] = os.getcwd()
    os.chdir(namespace["sandbox"])


def _teardown(namespace):
    os.chdir(namespace["_cwd"])
    remove_sandbox(namespace["sandbox"])


pytest_collect_file = Sybil(
    parsers=[ConsoleParser(), PythonCodeBlockParser(doctest_optionflags=ELLIPSIS | NORMALIZE_WHITESPACE),
             SkipParser()],
    patterns=["README.md", "docs/*.md", "docs/**/*.md"],
    setup=_setup,
    teardown=_teardown,
).pytest()
