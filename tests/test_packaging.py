"""Packaging and module structure (issue 8 §1, §4, §5).

* the wheel installs one top-level name, ``robolobes`` (and its dist-info), with every mapped
  subpackage and the built-in case data;
* the installed package imports from outside the repository (``python -I``), while the folder
  names (``cases``, ...) are not importable there;
* ``python -m robolobes --help`` exits 0;
* no module of a package shares its name with something the package re-exports (``import
  robolobes.lobes.solve as m`` would give the function, not the module);
* no library module imports a command-line module (AST scan).
"""

import ast
import importlib
import pkgutil
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ["core", "cases", "linearize", "lobes", "timedomain", "identify", "study", "workspace"]


def _run(args, cwd, timeout=300):
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    """Build the wheel from a copy of the sources (the build leaves nothing in the repository), in pip's
    isolated build environment (the pyproject asks for setuptools >= 68, as the README's install does)."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(".git", "build", "*.egg-info", "__pycache__", ".venv",
                                                             "tests", "bench", "docs", "robolobes-study", ".*"))
    r = _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp / "dist"),
              str(src)], cwd=tmp)
    assert r.returncode == 0, r.stderr[-2000:]
    (whl,) = (tmp / "dist").glob("robolobes-*.whl")
    return whl


def test_wheel_has_only_the_robolobes_namespace(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    top = {n.split("/")[0] for n in names}
    dist = [t for t in top if t.endswith(".dist-info")]
    assert len(dist) == 1 and top == {"robolobes", dist[0]}
    for pkg in PACKAGES + ["main.py", "__main__.py"]:
        assert any(n.startswith(f"robolobes/{pkg}") for n in names), pkg
    assert "robolobes/cases/data/tx200.toml" in names


def test_wheel_contents_import_alone(wheel, tmp_path):
    """Unpacked on its own (no editable finder involved: it is first on sys.path), the wheel's
    robolobes imports its subpackages and finds the built-in cases."""
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    code = ("import sys; sys.path.insert(0, sys.argv[1]); import robolobes.lobes, robolobes.cases as c; "
            "assert robolobes.lobes.__file__.startswith(sys.argv[1]), robolobes.lobes.__file__; "
            "print(c.load_case('tx200-aluminium').cut.spindle_rpm)")
    r = _run([sys.executable, "-I", "-c", code, str(site)], cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip() == "18700.0"


def test_installed_names_outside_the_repository(tmp_path):
    r = _run([sys.executable, "-I", "-c", "import robolobes.lobes, robolobes.cases, robolobes.linearize"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    for name in ("cases", "lobes", "linearize", "identify", "timedomain"):
        r = _run([sys.executable, "-I", "-c", f"import {name}"], cwd=tmp_path)
        assert r.returncode != 0 and "ModuleNotFoundError" in r.stderr, name


def test_python_m_robolobes_help(tmp_path):
    r = _run([sys.executable, "-I", "-m", "robolobes", "--help"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "usage" in r.stdout.lower()


def _modules():
    for pkg in PACKAGES:
        mod = importlib.import_module(f"robolobes.{pkg}")
        yield pkg, mod, [m.name for m in pkgutil.iter_modules(mod.__path__)]


def test_no_module_is_shadowed_by_a_reexport():
    for pkg, mod, subs in _modules():
        for name in subs:
            attr = getattr(mod, name, None)
            assert attr is None or attr is importlib.import_module(f"robolobes.{pkg}.{name}"), \
                f"robolobes.{pkg}.{name} is both a module and a re-exported {type(attr).__name__}"
    import robolobes.lobes.solver as m

    assert m.__name__ == "robolobes.lobes.solver"


def _is_cli(module: str) -> bool:
    return module.split(".")[-1] in ("cli", "main", "__main__")


def _imports(path: Path, package: str):
    """Absolute names of the modules imported by ``path`` (relative imports resolved in ``package``)."""
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(parts + ([node.module] if node.module else []))
            yield base
            yield from (f"{base}.{a.name}" for a in node.names)


def test_no_library_module_imports_a_cli_module():
    offenders = []
    for folder in PACKAGES:
        for path in sorted((ROOT / folder).rglob("*.py")):
            if _is_cli(path.stem):
                continue
            rel = path.relative_to(ROOT / folder).with_suffix("")
            package = ".".join(["robolobes", folder, *rel.parts[:-1]])
            offenders += [f"{folder}/{rel}.py imports {m}" for m in _imports(path, package) if _is_cli(m)]
    assert offenders == []


def test_the_ast_scan_can_fail(tmp_path):
    """The scan sees the three forms of a CLI import (checked on a synthetic file)."""
    f = tmp_path / "x.py"
    f.write_text("from .cli import run\nimport robolobes.lobes.cli\nfrom robolobes.linearize import cli\n")
    found = [m for m in _imports(f, "robolobes.lobes") if _is_cli(m)]
    assert found.count("robolobes.lobes.cli") == 2 and "robolobes.linearize.cli" in found


@pytest.mark.parametrize("folder,package", [(p, f"robolobes.{p}") for p in PACKAGES] + [("app", "robolobes")])
def test_root_folder_does_not_load_a_second_copy(folder, package):
    """From the repository root, where the design's folders are on sys.path, ``import lobes`` must
    not give a second copy of robolobes.lobes: an ImportError naming the package to import."""
    r = _run([sys.executable, "-c", f"import {folder}"], cwd=ROOT)
    assert r.returncode != 0
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError") and f"import {package} instead" in last, last
    r = _run([sys.executable, "-c", f"import {package}"], cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]


def _imports_of(path: Path, package: str, modules: set) -> set:
    """robolobes modules a module imports (anywhere in it, except under ``if TYPE_CHECKING``)."""
    tree = ast.parse(path.read_text())
    typing_only = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
                   and "TYPE_CHECKING" in ast.unparse(node.test) for n in ast.walk(node)}
    out = set()
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom):
            parts = package.split(".")
            base = ".".join(parts[:len(parts) - node.level + 1] + [node.module or ""]).strip(".") if node.level \
                else node.module or ""
            out |= {f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names}
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
    return out & modules


def test_no_import_cycles():
    """No chain of imports leads from a module back to itself (a depth-first search of the graph
    of every robolobes module's imports, read from the source)."""
    folders = {"app": "robolobes", **{p: f"robolobes.{p}" for p in PACKAGES}}
    files = {(pkg if f.stem == "__init__" else f"{pkg}.{f.stem}"): (f, pkg)
             for folder, pkg in folders.items() for f in (ROOT / folder).glob("*.py")}
    graph = {m: _imports_of(f, pkg, set(files)) - {m} for m, (f, pkg) in files.items()}
    cycles = []

    def visit(m, path):
        for t in graph[m]:
            if t in path:
                cycles.append(path[path.index(t):] + [t])
            elif t not in done:
                done.add(t)
                visit(t, path + [t])

    done = set()
    for m in graph:
        visit(m, [m])
    assert not cycles, [" -> ".join(c) for c in cycles]


def test_linearize_lazy_names_resolve():
    """robolobes.linearize loads its names on first use: each listed name has a home and resolves."""
    import robolobes.linearize as L

    assert set(L.__all__) == set(L._HOME)
    for name in L.__all__:
        assert getattr(L, name) is getattr(importlib.import_module(f"robolobes.linearize.{L._HOME[name]}"), name)
