"""Load capacity of the differential's spur meshes by ISO 6336 method B (docs/capacity.md):

* :mod:`.data`: materials and rating conditions (``spurdiff/data/materials.toml``), the FMU's
  rating parameters, the load-sharing factor K_gamma;
* :mod:`.loads`: each mesh's face width (the axial overlap), the pitch-line speed, nominal forces;
* :mod:`.factors`: every ISO 6336 factor as a plain function (K_v, K_Hbeta / K_Fbeta, K_Halpha /
  K_Falpha, Z_H, Z_E, Z_eps, Z_B / Z_D, Y_F, Y_S, Y_B);
* :mod:`.stiffness`: the ISO 6336-1 mesh stiffness and its comparison with the IMPACT law;
* :mod:`.rating`: the rating of a mesh and of the set (static and long-life safety factors);
* :mod:`.life`: the limited-life check of a duty cycle (``spurdiff/data/duty_cycle.toml``);
* :mod:`.watch`: the largest stresses over a run.

Units: SI at every interface (N, m, Pa, m/s); the ISO formulas are written in N, mm, um and N/mm^2
inside. The names of the submodules are re-exported here (``capacity.rate_mesh``...).

May import: :mod:`spurdiff.gears` (geometry, axial layout) and the core.
"""
from spurdiff.gears.capacity.data import *          # noqa: F401,F403
from spurdiff.gears.capacity.data import __all__ as _data
from spurdiff.gears.capacity.factors import *       # noqa: F401,F403
from spurdiff.gears.capacity.factors import __all__ as _factors
from spurdiff.gears.capacity.life import *          # noqa: F401,F403
from spurdiff.gears.capacity.life import __all__ as _life
from spurdiff.gears.capacity.loads import *         # noqa: F401,F403
from spurdiff.gears.capacity.loads import __all__ as _loads
from spurdiff.gears.capacity.rating import *        # noqa: F401,F403
from spurdiff.gears.capacity.rating import __all__ as _rating
from spurdiff.gears.capacity.stiffness import *     # noqa: F401,F403
from spurdiff.gears.capacity.stiffness import __all__ as _stiffness
from spurdiff.gears.capacity.watch import *         # noqa: F401,F403
from spurdiff.gears.capacity.watch import __all__ as _watch

__all__ = [*_data, *_factors, *_life, *_loads, *_rating, *_stiffness, *_watch]
