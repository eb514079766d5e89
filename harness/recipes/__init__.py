"""Recipes for using the FMUs in your own tool (docs/use-the-fmu.md): standalone scripts and a C host
that ``spurdiff starter`` copies out, ready to run. They import nothing from this package."""
