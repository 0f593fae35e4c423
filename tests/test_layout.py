"""The package layout shows the data flow, and imports flow one way.

Every module of vrcal belongs to a layer; a module may import only from its own layer or
from layers below it. A cycle, or a model module that reaches into discovery, fails here.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "vrcal"

#: Layers, lowest first. A module imports only from its own layer or lower ones.
LAYERS = [
    {"vrcal", "vrcal.errors", "vrcal.fileio", "vrcal.textout"},
    {"vrcal.model"},
    {"vrcal.inverse", "vrcal.measurements"},
    {"vrcal.drop"},
    {"vrcal.discovery"},
    {"vrcal.engines"},
    {"vrcal.scenes", "vrcal.plots"},
    {"vrcal.cli", "vrcal.options", "vrcal.__main__"},
]


def _owner(module):
    """The layer key of a dotted module name: the subpackage, or the top-level module."""
    parts = module.split(".")
    if len(parts) >= 2 and (PACKAGE / parts[1]).is_dir():
        return ".".join(parts[:2])
    if len(parts) >= 2:
        return ".".join(parts[:2])
    return module


def _rank(module):
    key = _owner(module)
    for i, layer in enumerate(LAYERS):
        if key in layer:
            return i
    raise AssertionError(f"{module} ({key}) belongs to no layer of tests/test_layout.py: add it")


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        yield ".".join(parts), path


def _imports(path, module):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("vrcal"):
                    yield alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module or ""
            if name.startswith("vrcal"):
                if name == "vrcal":
                    for alias in node.names:
                        yield f"vrcal.{alias.name}" if alias.name != "__version__" else "vrcal"
                else:
                    yield name


@pytest.mark.parametrize("module,path", list(_modules()), ids=lambda x: str(x) if isinstance(x, str) else "")
def test_imports_flow_one_way(module, path):
    rank = _rank(module)
    for target in _imports(path, module):
        assert _rank(target) <= rank, f"{module} imports {target}, a layer above it"


def test_subpackages_say_what_they_own():
    for init in sorted(PACKAGE.glob("*/__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8")))
        assert doc and len(doc) > 80, f"{init.parent.name}/__init__.py needs a docstring saying what it owns"


def test_design_card_files_stay_where_users_expect_them():
    for name in ("cli.py", "inverse.py", "plots.py", "standards.yaml"):
        assert (PACKAGE / name).is_file(), name
