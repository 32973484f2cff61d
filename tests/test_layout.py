"""The layout kept readable: the guides stay short, no module or class of native/ and addon/
grows past its limit, and no module of either package imports itself back through others
(at module level or inside a function). Reads the sources only: no bpy, no GL."""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("native", "addon")
README_WORDS = 3000
BENCHMARKS_LINES = 600
FILE_LINES = 600
CLASS_LINES = 400


def sources():
    return sorted(path for package in PACKAGES for path in (ROOT / package).rglob("*.py"))


def module_name(path, root):
    """``package.sub.module`` of a file under ``root`` (a package's __init__ is the package)."""
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path, root, modules):
    """The modules of ``modules`` (dotted names) that the file imports, anywhere in it:
    relative imports and absolute ones of the same packages, at module level or within a
    function. ``from . import name`` names the module ``name`` where there is one, else the
    package."""
    name = module_name(path, root)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:     # from . (the package), from .. (its parent), ...
                parts = package.split(".")
                parts = parts[:max(len(parts) - node.level + 1, 0)]
                source = ".".join(parts + ([node.module] if node.module else []))
            else:
                source = node.module
            found.update(f"{source}.{alias.name}" if f"{source}.{alias.name}" in modules
                         else source for alias in node.names)
    return {module for module in found if module in modules and module != name}


def import_cycles(package_dir):
    """Each cycle of imports among the modules of one package (its folder): a list of the
    sorted module names of every strongly connected component of more than one module."""
    root = package_dir.parent
    paths = sorted(package_dir.rglob("*.py"))
    modules = {module_name(path, root) for path in paths}
    graph = {module_name(path, root): imported_modules(path, root, modules) for path in paths}
    # Tarjan's strongly connected components, iteratively.
    index, low, on_stack, stack, components = {}, {}, set(), [], []
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, successors = work[-1]
            for successor in successors:
                if successor not in index:
                    index[successor] = low[successor] = len(index)
                    stack.append(successor)
                    on_stack.add(successor)
                    work.append((successor, iter(sorted(graph[successor]))))
                    break
                if successor in on_stack:
                    low[node] = min(low[node], index[successor])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        components.append(sorted(component))
    return sorted(components)


def test_readme_is_under_the_word_limit():
    words = len((ROOT / "README.md").read_text(encoding="utf-8").split())
    assert words < README_WORDS, f"README.md has {words} words: the limit is {README_WORDS}"


def test_benchmarks_is_under_the_line_limit():
    lines = len((ROOT / "BENCHMARKS.md").read_text(encoding="utf-8").splitlines())
    assert lines < BENCHMARKS_LINES, (f"BENCHMARKS.md has {lines} lines: the limit is "
                                      f"{BENCHMARKS_LINES}")


def test_every_module_is_under_the_line_limit():
    long = {str(path.relative_to(ROOT)): lines for path in sources()
            if (lines := len(path.read_text(encoding="utf-8").splitlines())) >= FILE_LINES}
    assert not long, f"modules of {FILE_LINES} lines or more (the limit): {long}"


def test_every_class_is_under_the_line_limit():
    long = {}
    for path in sources():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if (isinstance(node, ast.ClassDef)
                    and (lines := node.end_lineno - node.lineno + 1) >= CLASS_LINES):
                long[f"{path.relative_to(ROOT)}:{node.name}"] = lines
    assert not long, f"classes of {CLASS_LINES} lines or more (the limit): {long}"


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_cycle_within_a_package(package):
    cycles = import_cycles(ROOT / package)
    assert not cycles, f"modules of {package}/ that import each other in a cycle: {cycles}"


def write_package(folder, files):
    for name, text in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return folder


def test_the_cycle_check_finds_cycles_through_functions_and_subpackages(tmp_path):
    package = write_package(tmp_path / "fake", {
        "__init__.py": "from .first import one\n",
        "first.py": "from . import second\n\ndef one():\n    return second.two()\n",
        # Through a function-level import, as a cycle broken only in time.
        "second.py": "def two():\n    from .first import one\n    return one\n",
        "inner/__init__.py": "",
        "inner/third.py": "from ..fourth import four\n",
        "fourth.py": "import fake.inner.third\nfour = 4\n",
        "apart.py": "from .first import one\nfrom .inner import third\n",
    })
    assert import_cycles(package) == [["fake.first", "fake.second"],
                                      ["fake.fourth", "fake.inner.third"]]


def test_the_cycle_check_passes_a_package_without_cycles(tmp_path):
    package = write_package(tmp_path / "fake", {
        "__init__.py": "from .first import one\nfrom . import second\n",
        "first.py": "from .second import two\n\ndef one():\n    from . import third\n"
                    "    return two() + third.three\n",
        "second.py": "import numpy\n\ndef two():\n    return 2\n",
        "third.py": "three = 3\n",
    })
    assert import_cycles(package) == []
