"""numpy's subpackages the FMUs' runtimes leave out (``runtime_bundle.NUMPY_UNUSED``) are reached
by nothing the FMUs carry: no kept numpy module imports them outside numpy's lazy attributes and
its test runner, and the models' package names none of them, nor numpy.linalg (a stand-in without
LAPACK in the FMUs' numpy: harness/build/numpy_blas.py)."""
from __future__ import annotations

import ast
from pathlib import Path

from harness.build import runtime_bundle
from harness.common.paths import physics_package

# (file relative to numpy/, function) where an import of a left-out subpackage is allowed: numpy's
# lazy attributes (np.random...: nothing of ours asks for them) and np.test(), numpy's own test runner
ALLOWED = {("__init__.py", "__getattr__"), ("_pytesttester.py", "__call__")}


def _imports(tree: ast.AST, package: str):
    """(imported module, enclosing function name or None, line) for every import in ``tree`` of a
    module of ``package`` (a dotted name: relative imports resolved against it)."""
    def walk(node, func):
        for child in ast.iter_child_nodes(node):
            f = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else func
            if isinstance(child, ast.Import):
                for a in child.names:
                    yield a.name, func, child.lineno
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package.split(".")[:len(package.split(".")) - child.level + 1]
                    mod = ".".join(base + ([child.module] if child.module else []))
                else:
                    mod = child.module or ""
                yield mod, func, child.lineno
                for a in child.names:       # from numpy import random / from . import fft
                    yield f"{mod}.{a.name}", func, child.lineno
            yield from walk(child, f)
    yield from walk(tree, None)


# what the models may not name: the left-out subpackages and numpy.linalg, whose extension modules the
# FMUs' numpy replaces by a stand-in that raises (the models solve with spurdiff.numerics.lu_solve)
NOT_FOR_MODELS = (*runtime_bundle.NUMPY_UNUSED, "linalg")


def _left_out(name: str, subs: tuple = runtime_bundle.NUMPY_UNUSED) -> str | None:
    for sub in subs:
        if name == f"numpy.{sub}" or name.startswith(f"numpy.{sub}."):
            return sub
    return None


def test_kept_numpy_modules_never_import_the_left_out_subpackages():
    src = runtime_bundle.numpy_folder()
    skip = [src / d for d in runtime_bundle.NUMPY_SKIP_DIRS]
    checked, found = 0, []
    for path in sorted(src.rglob("*.py")):
        if (any(path.is_relative_to(d) for d in skip) or runtime_bundle.TEST_FOLDERS & set(path.parts)
                or path.name.startswith(runtime_bundle.NUMPY_SKIP_PREFIXES)):
            continue      # what the runtimes leave out
        rel = path.relative_to(src)
        package = ".".join(["numpy", *rel.parent.parts])    # a module's package, or the package itself
        checked += 1
        for name, func, line in _imports(ast.parse(path.read_bytes()), package):
            if _left_out(name) and (rel.as_posix(), func) not in ALLOWED:
                found.append(f"numpy/{rel.as_posix()}:{line} imports {name} (in {func or 'the module'})")
    assert checked > 100, f"only {checked} numpy modules read from {src}"
    assert not found, "a kept numpy module imports a left-out subpackage:\n" + "\n".join(found)


def test_the_allowed_imports_are_where_the_test_says():
    """The allowances above still exist (numpy moved them: the test must be looked at again)."""
    src = runtime_bundle.numpy_folder()
    seen = set()
    for rel, func in ALLOWED:
        for name, f, _ in _imports(ast.parse((src / rel).read_bytes()), "numpy"):
            if _left_out(name) and f == func:
                seen.add((rel, func))
    assert seen == ALLOWED


def test_the_models_name_no_left_out_subpackage():
    found = []
    for path in sorted(physics_package().rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        tree = ast.parse(text)
        for name, _, line in _imports(tree, "spurdiff"):
            if _left_out(name, NOT_FOR_MODELS):
                found.append(f"{path}:{line} imports {name}")
        for node in ast.walk(tree):     # np.random.x, numpy.fft.y as attributes of the module
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in ("np", "numpy") and node.attr in NOT_FOR_MODELS):
                found.append(f"{path}:{node.lineno} uses {node.value.id}.{node.attr}")
    assert not found, "\n".join(found)


def test_a_planted_import_is_found(tmp_path: Path):
    """The reader finds the forms of import it is meant to find (relative, from-import of a name)."""
    code = "from . import random\nfrom ..fft import x\nimport numpy.polynomial.chebyshev\ndef f():\n    from numpy import testing\n"
    names = {n for n, _, _ in _imports(ast.parse(code), "numpy.lib")}
    assert {"numpy.lib.random", "numpy.fft", "numpy.polynomial.chebyshev", "numpy.testing"} <= names
    assert _left_out("numpy.fft") == "fft" and _left_out("numpy.fftx") is None
