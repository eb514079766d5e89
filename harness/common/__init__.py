"""Shared pieces of the harness: where things are read and written (:mod:`.paths`), writing result
files safely (:mod:`.outputs`), text that reaches the terminal (:mod:`.messages`), Ctrl-C during a
run (:mod:`.interrupt`), and the import graph of the two packages (:mod:`.import_graph`).

May import: the standard library and :mod:`spurdiff` only; no other harness package.
"""
