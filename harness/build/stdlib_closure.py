"""The static import closure of the FMUs' package (what :mod:`harness.build.runtime_bundle` carries of the
standard library beyond the trace), without the code a module runs only as a script.

``modulefinder`` follows every import in a module's code, in functions too, which is what keeps a
rarely taken path's import in the runtime. It also follows the imports of a module's
``if __name__ == "__main__":`` block and of the functions only that block calls (``pickle._test``
imports doctest, ``inspect._main`` argparse, ``heapq``'s block doctest...), which never run when the
module is imported, as the FMUs import everything. Through them the closure took doctest, unittest,
asyncio, concurrent, multiprocessing, xmlrpc, pdb, pydoc, http.server and more: about a sixth of the
standard library's bytes the runtime carried, copied by every host's unzip.

:class:`ScriptlessFinder` scans each pure-Python module with those parts left out: the top-level
``if __name__ == "__main__":`` blocks, and the top-level functions such a block names that nothing
else in the module refers to (by name, attribute or ``__all__``; repeated, so a helper only those
functions call goes too). Everything else is scanned as modulefinder does.
"""
from __future__ import annotations

import ast
import modulefinder

_FUNCTIONS = (ast.FunctionDef, ast.AsyncFunctionDef)


def is_main_guard(node: ast.stmt) -> bool:
    """``if __name__ == "__main__":`` (either operand order) at a module's top level."""
    if not (isinstance(node, ast.If) and isinstance(node.test, ast.Compare) and len(node.test.ops) == 1
            and isinstance(node.test.ops[0], ast.Eq)):
        return False
    sides = (node.test.left, node.test.comparators[0])
    return (any(isinstance(s, ast.Name) and s.id == "__name__" for s in sides)
            and any(isinstance(s, ast.Constant) and s.value == "__main__" for s in sides))


def _names(node: ast.AST) -> set[str]:
    """The names a node refers to: variables, attributes, and string constants (``__all__``'s entries)."""
    out = set()
    for x in ast.walk(node):
        if isinstance(x, ast.Name):
            out.add(x.id)
        elif isinstance(x, ast.Attribute):
            out.add(x.attr)
        elif isinstance(x, ast.Constant) and isinstance(x.value, str):
            out.add(x.value)
    return out


def without_script_parts(tree: ast.Module) -> tuple[ast.Module, list[str]]:
    """``tree`` without its main blocks and the functions only they use (see the module docstring), and
    the names of the functions left out."""
    guards = [n for n in tree.body if is_main_guard(n)]
    if not guards:
        return tree, []
    body = [n for n in tree.body if not is_main_guard(n)]
    named = set().union(*(_names(g) for g in guards))
    refs = [(n, _names(n)) for n in body]          # each statement's names, once
    dropped: set[str] = set()
    while True:
        kept = [(n, r) for n, r in refs if not (isinstance(n, _FUNCTIONS) and n.name in dropped)]
        more = {n.name for n, _ in kept if isinstance(n, _FUNCTIONS) and n.name in named
                and not any(n.name in r for other, r in kept if other is not n)}
        if not more:
            break
        dropped |= more
        named = named.union(*(r for n, r in kept if isinstance(n, _FUNCTIONS) and n.name in more))
    tree.body = [n for n in body if not (isinstance(n, _FUNCTIONS) and n.name in dropped)]
    return tree, sorted(dropped)


class ScriptlessFinder(modulefinder.ModuleFinder):
    """modulefinder scanning pure-Python modules without their script parts (:func:`without_script_parts`)."""

    def load_module(self, fqname, fp, pathname, file_info):
        if file_info[2] != modulefinder._PY_SOURCE:
            return super().load_module(fqname, fp, pathname, file_info)
        tree, _ = without_script_parts(ast.parse(fp.read(), pathname))
        code = compile(tree, pathname, "exec")
        m = self.add_module(fqname)
        m.__file__ = pathname
        m.__code__ = code
        self.scan_code(code, m)
        return m


__all__ = ["ScriptlessFinder", "is_main_guard", "without_script_parts"]
