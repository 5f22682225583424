"""The tests mirror the package (tests/<package>/test_*.py): nothing but conftest.py sits at the
root of tests/, each test folder is a package (test modules of the same name in two folders), and
no test module (nor a benchmark) imports a test module: what tests share is in tests/support/ or
a conftest.py. Every import counts, those inside functions too."""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).parents[1]
AT_THE_ROOT = {"__init__.py", "conftest.py"}


def is_test_module(path: Path) -> bool:
    return path.suffix == ".py" and (path.name.startswith("test_") or path.name == "conftest.py")


def imported_files(path: Path, root: Path) -> set[Path]:
    """The files under `root` (the tests/ package) that `path` imports, by absolute imports of
    `root.name` or by relative ones."""
    package = path.relative_to(root.parent).parent.parts
    found: set[Path] = set()

    def files_of(dotted: tuple[str, ...]) -> set[Path]:
        if not dotted or dotted[0] != root.name:
            return set()
        base = root.parent.joinpath(*dotted)
        return {p for p in (base.with_suffix(".py"), base / "__init__.py") if p.exists()}

    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                found |= files_of(tuple(alias.name.split(".")))
        elif isinstance(node, ast.ImportFrom):
            anchor = package[: len(package) - node.level + 1] if node.level else ()
            module = (*anchor, *(node.module or "").split(".")) if node.module else anchor
            found |= files_of(module)
            for alias in node.names:  # `from tests.server import test_server`
                found |= files_of((*module, alias.name))
    return found


def imports_of_test_modules(root: Path, others: Path | None = None) -> dict[str, list[str]]:
    """Each module of `root` (or of `others`, a folder beside it) that imports a test module."""
    found: dict[str, list[str]] = {}
    importers = [*root.rglob("*.py"), *(others.rglob("*.py") if others else ())]
    for path in sorted(importers):
        imported = sorted(str(f.relative_to(root)) for f in imported_files(path, root) if is_test_module(f))
        if imported:
            found[str(path.relative_to(root.parent))] = imported
    return found


def test_no_file_but_conftest_sits_at_the_root_of_tests() -> None:
    at_root = {p.name for p in TESTS.glob("*.py")}
    assert at_root - AT_THE_ROOT == set()


def test_every_folder_of_python_tests_is_a_package() -> None:
    folders = {p.parent for p in TESTS.rglob("*.py")}
    assert sorted(str(f.relative_to(TESTS)) for f in folders if not (f / "__init__.py").exists()) == []


def test_no_test_module_imports_another_test_module_nor_a_benchmark_one() -> None:
    assert imports_of_test_modules(TESTS, TESTS.parent / "bench") == {}


def test_the_import_finder_finds_test_modules_however_imported(tmp_path: Path) -> None:
    root = tmp_path / "tests"
    for name in ("__init__.py", "conftest.py", "support/__init__.py", "support/rig.py", "a/__init__.py"):
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text("")
    (root / "a" / "test_one.py").write_text("from tests.support.rig import x\n")
    (root / "a" / "test_two.py").write_text("def f():\n    from tests.a.test_one import y\n")
    (root / "a" / "test_three.py").write_text("from . import test_one\nfrom ..conftest import z\n")
    (root / "a" / "test_four.py").write_text("import tests.a.test_two\nfrom tests.a import test_three\n")
    (tmp_path / "bench").mkdir()
    (tmp_path / "bench" / "control.py").write_text("from tests.conftest import free_port\n")
    assert imports_of_test_modules(root, tmp_path / "bench") == {
        "bench/control.py": ["conftest.py"],
        "tests/a/test_four.py": ["a/test_three.py", "a/test_two.py"],
        "tests/a/test_three.py": ["a/test_one.py", "conftest.py"],
        "tests/a/test_two.py": ["a/test_one.py"],
    }
