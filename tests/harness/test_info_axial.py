"""`spurdiff info` shows the axial layout, its stack-up findings and K for both handednesses and
both leading suns (issue 41)."""
from __future__ import annotations

from harness.measure.info import info_text


def test_info_shows_the_axial_layout_and_the_3d_locking():
    text = info_text()
    assert "WARNING mesh-width: mesh B2 is 17.00 mm wide" in text
    assert "mesh B2   24.00 mm ..  41.00 mm  face width 17.00 mm" in text
    rows = [line.split() for line in text.splitlines() if line.startswith(("endReactions ", "planar ", "linearPressure "))]
    k = {(r[0], r[1], r[2]): r[3:6] for r in rows if len(r) >= 7 and r[1] in ("leading", "trailing")}
    assert k[("endReactions", "leading", "drive")] == ["0.2342", "0.2326", "0.2326"]
    assert k[("endReactions", "trailing", "drive")] == ["0.2184", "0.2182", "0.2182"]
    assert k[("planar", "leading", "drive")] == ["0.1779", "0.1779", "0.1779"]
    assert k[("linearPressure", "leading", "coast")] == ["0.2312", "0.2330", "0.2312"]
