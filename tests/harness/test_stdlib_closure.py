"""The runtime's static closure leaves out what a module runs only as a script (harness/build/stdlib_closure.py),
and nothing else: its main block, the functions only that block uses, and no function another part of
the module, an attribute or ``__all__`` names."""
from __future__ import annotations

import ast
import textwrap

from harness.build import runtime_bundle
from harness.build.stdlib_closure import ScriptlessFinder, is_main_guard, without_script_parts

MODULE = textwrap.dedent('''
    import json
    __all__ = ["exported"]

    def _test():                 # only the main block calls it
        import doctest
        return _helper()

    def _helper():               # only _test calls it
        import argparse

    def used():                  # the main block calls it, and so does the module's code
        import csv

    def exported():              # the main block calls it; __all__ exports it
        import wave

    def by_attribute():
        import zipfile

    TABLE = {"f": used}
    OBJ = type("O", (), {})
    OBJ.by_attribute = None      # an attribute of that name: kept

    if __name__ == "__main__":
        import pdb
        _test(); used(); exported(); by_attribute()
''')


def test_the_main_block_and_the_functions_only_it_uses_are_left_out():
    tree, dropped = without_script_parts(ast.parse(MODULE))
    assert dropped == ["_helper", "_test"]
    names = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert names == {"used", "exported", "by_attribute"}
    assert not any(is_main_guard(n) for n in tree.body)
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    assert imported == {"json", "csv", "wave", "zipfile"}


def test_a_module_without_a_main_block_is_scanned_whole():
    src = "def _test():\n    import doctest\n"
    tree, dropped = without_script_parts(ast.parse(src))
    assert dropped == [] and len(tree.body) == 1


def test_the_guard_is_recognised_either_way_round_and_only_as_an_equality():
    for src, want in (('if __name__ == "__main__": pass', True), ('if "__main__" == __name__: pass', True),
                      ('if __name__ != "__main__": pass', False), ('if __name__ == "spam": pass', False),
                      ('if x == "__main__": pass', False)):
        assert is_main_guard(ast.parse(src).body[0]) is want, src


def test_the_finder_no_longer_reaches_the_test_and_debug_tools_through_script_parts(tmp_path):
    """pickle's _test (doctest) and inspect's _main are script parts: a module importing pickle and
    inspect reaches neither doctest, unittest, pdb, pydoc nor asyncio any more, and still reaches what
    pickle and inspect import to run (copyreg, _compat_pickle, dis, tokenize). (argparse it still
    reaches: py_compile exports its main, which imports it.)"""
    (tmp_path / "m.py").write_text("import pickle, inspect\n")
    f = ScriptlessFinder(path=[str(tmp_path), str(runtime_bundle.STDLIB), str(runtime_bundle.DYNLOAD)],
                         excludes=sorted(runtime_bundle.DENY))
    f.import_hook("m")
    assert {"copyreg", "_compat_pickle", "dis", "tokenize"} <= set(f.modules)
    assert not {"doctest", "unittest", "pdb", "pydoc", "asyncio"} & set(f.modules)


def test_the_runtime_carries_no_test_or_debug_tool(fmu_files):
    """The built runtime's module list (the trace, start-up and this closure): none of the tools that
    came in only through script parts."""
    import io
    import zipfile

    with zipfile.ZipFile(fmu_files["SpurDifferential"]) as z:
        common = zipfile.ZipFile(io.BytesIO(z.read("resources/runtime/common.zip")))
        stdlib = zipfile.ZipFile(io.BytesIO(common.read(common.namelist()[0])))
        tops = {n.split("/")[0].removesuffix(".pyc") for n in stdlib.namelist()}
    assert {"json", "dataclasses", "ctypes", "encodings", "pathlib"} <= tops
    assert not {"doctest", "unittest", "pdb", "pydoc", "asyncio", "multiprocessing", "xmlrpc"} & tops, tops
