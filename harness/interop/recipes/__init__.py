"""Recipes for using the FMUs in your own tool (docs/use-the-fmu.md): standalone scripts and a C host
that ``spurdiff starter`` copies out, ready to run. They import nothing from this package.

May import: nothing of the harness nor of :mod:`spurdiff` (they run where neither is installed).
"""
