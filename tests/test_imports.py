"""The import graph of ``spurdiff`` and ``harness``, read from the source with ``ast`` (nothing
imported): no cycle, the harness's library modules never import ``harness.cli``, spurdiff's
layers run one way (fmi over the models over the gear set over the core), so do the harness's
(cli over interop over measure, sweep and check over run over fmi and build over scene over common),
and the picture in docs/architecture.md is the one the code draws (``python -m harness.cli.tools.import_graph``)."""
from __future__ import annotations

import ast

from harness.common import import_graph as ig


def test_no_import_cycle_in_spurdiff_or_harness():
    g = ig.graph()
    assert any(n.startswith("spurdiff.") for n in g) and any(n.startswith("harness.") for n in g)
    assert ig.cycles(g) == []


def test_the_graph_sees_a_cycle_a_lazy_import_and_a_relative_one(tmp_path, monkeypatch):
    """The checks can fail: a planted two-module cycle (one side imported inside a function, one
    relative) is found, a TYPE_CHECKING import is not an arrow."""
    pkg = tmp_path / "spurdiff"
    (pkg / "gears").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "errors.py").write_text("def f():\n    from spurdiff.gears import geometry\n")
    (pkg / "gears" / "__init__.py").write_text("")
    (pkg / "gears" / "geometry.py").write_text("from .. import errors\nfrom typing import TYPE_CHECKING\n"
                                               "if TYPE_CHECKING:\n    from spurdiff.gears import checks\n")
    (pkg / "gears" / "checks.py").write_text("from spurdiff.gears.geometry import x\n")
    monkeypatch.setattr(ig, "SOURCES", {"spurdiff": pkg})
    g = ig.graph()
    assert g["spurdiff.gears.geometry"] == {"spurdiff.errors"}
    assert g["spurdiff.gears.checks"] == {"spurdiff.gears.geometry"}
    assert ig.cycles(g) == [["spurdiff.errors", "spurdiff.gears.geometry"]]
    assert ig.layer_violations(g) == ["spurdiff.errors -> spurdiff.gears.geometry (spurdiff may not import "
                                      "spurdiff.gears)"]


def test_harness_library_modules_never_import_the_cli():
    assert ig.cli_imports(ig.graph()) == []


def test_spurdiff_layers_run_one_way():
    """fmi over differential and vehicle (siblings: neither imports the other) over gears over the
    core; spurdiff never imports the harness."""
    g = ig.graph()
    assert ig.layer_violations(g) == []
    assert {ig.layer_of(n)[1] for n in g if n.startswith("spurdiff")} == {p for ps in ig.LAYERS for p in ps}


def test_harness_packages_run_one_way():
    """Every harness package has its place in ``HARNESS_LAYERS`` and imports only the layers below
    it, never a sibling of its own layer."""
    g = ig.graph()
    assert ig.harness_unplaced() == []
    assert ig.harness_layer_violations(g) == []
    assert {ig.harness_package(n) for n in g if n.startswith("harness")} == (
        {p for ps in ig.HARNESS_LAYERS for p in ps} | set(ig.HARNESS_FREE))


def test_the_harness_layer_check_can_fail():
    """Planted arrows: up a layer, sideways between siblings, out of a package in no layer; arrows
    inside one package, into spurdiff, and out of a ``python -m`` entry are allowed."""
    g = {"harness.scene.spec": {"harness.run.master", "harness.scene.schema", "spurdiff.errors"},
         "harness.measure.info": {"harness.sweep.run", "harness.run.report"},
         "harness.measure.accuracy.__main__": {"harness.cli.accuracy"},
         "harness.newthing.x": {"harness.common.paths"}}
    assert ig.harness_layer_violations(g) == [
        "harness.measure.info -> harness.sweep.run (harness.measure may not import harness.sweep)",
        "harness.newthing.x -> harness.common.paths (harness.newthing lies in no layer)",
        "harness.scene.spec -> harness.run.master (harness.scene may not import harness.run)"]


def test_spurdiff_has_about_a_dozen_modules_at_the_top():
    top = [n for n in ig.modules() if n.startswith("spurdiff.") and n.count(".") == 1]
    assert len(top) <= 12, top


# harness packages with more than a dozen modules at their top, and why
CROWDED = {"harness.cli": "one module per spurdiff command (14); the python -m tools are in harness.cli.tools"}


def test_every_harness_package_has_about_a_dozen_modules_at_its_top():
    packages = [n for n, m in ig.modules().items() if m.is_package and n.startswith("harness")]
    assert "harness.run" in packages and "harness.measure.bench" in packages
    for p in packages:
        if p not in CROWDED:
            assert len(ig.top_modules(p)) <= 12, (p, ig.top_modules(p))
    assert len(ig.top_modules("harness")) <= 2   # only the python -m entry beside the packages


def test_every_package_init_says_what_it_holds_and_may_import():
    # the two roots say what their packages hold and in which order; data-only packages hold no code;
    skip = {"spurdiff", "spurdiff.data", *ig.HARNESS_FREE}
    checked = [name for name, mod in ig.modules().items() if mod.is_package and name not in skip]
    assert "harness.run" in checked and "spurdiff.gears" in checked
    for name in checked:
        doc = ast.get_docstring(ast.parse(ig.modules()[name].path.read_text())) or ""
        assert "May import" in doc, name


def test_the_architecture_picture_is_the_one_the_code_draws():
    doc = ig.ROOT / "docs" / "architecture.md"
    assert ig.current_picture(doc) == ig.picture(), "run: python -m harness.cli.tools.import_graph"
