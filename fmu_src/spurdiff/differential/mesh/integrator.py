"""Adaptive linearly implicit integrators for the stiff mesh dynamics: the Rosenbrock-W method
ROS34PW2 of Rang and Angermann (2005), the default, and the Rosenbrock method RODAS5P of
Steinebach (2023) (``solver.method``), tableaux as data.

Method (Hairer and Wanner, Solving ODEs II, sec. IV.7), for ``y' = f(y)`` (our system is autonomous
within a communication step), ``s = 4`` stages::

    (I - gamma h J) k_i = h f(y + sum_j alpha_ij k_j) + h J sum_{j<i} gamma_ij k_j
    y_1 = y + sum_i b_i k_i,      error estimate  sum_i (b_i - bhat_i) k_i

implemented in the transformed variables ``u_i = sum_j Gamma_ij k_j`` so that only the matrix
``W = I/(gamma h) - J`` is factored (once per step) and no product with ``J`` is needed::

    W u_i = f(y + sum_j a_ij u_j) + sum_{j<i} (c_ij / h) u_j,    y_1 = y + sum_i m_i u_i

with ``a = alpha Gamma^-1``, ``c = diag(1/gamma) - Gamma^-1``, ``m = b Gamma^-1``.

Why ROS34PW2 (J. Rang, L. Angermann, BIT 45 (2005) 761-787; tableau as registered in PETSc's
``TSROSWRA34PW2``):

* L-stable and stiffly accurate: the mesh modes (several kHz, and the contact damping makes them
  strongly overdamped, eigenvalues down to -1e6 1/s) are damped, not amplified, for any step;
  a communication step of 1e-2 s is as stable as one of 1e-5 s.
* a W-method: order 3 holds for any approximation of the Jacobian, so the analytic Jacobian of the
  small system only has to be good for stability, not exact (friction laws, clipped forces).
* linearly implicit: at most one LU of an 8x8 (10x10) matrix and four solves per step, no Newton
  iteration that can fail to converge at contact onset; the LU serves on while the Jacobian and
  the step size are unchanged (:mod:`spurdiff.differential.mesh.stepper`).
* embedded order 2 for step-size control, and a dense output (PETSc ``binterpt``), used for the
  Simpson quadrature of the dissipated power: of order 3 only with the exact Jacobian, of order 2
  as a W-method (an approximate Jacobian: the order conditions' trees with a matrix vertex of
  order 3 fail; tests/physics/mesh/test_tableau_order_conditions.py).

The second method, RODAS5P (G. Steinebach, "Construction of Rosenbrock-Wanner method Rodas5P and
numerical benchmarks within the Julia Differential Equations package", BIT Numer. Math. 63 (2023)
27; the coefficients as published there and registered in OrdinaryDiffEq.jl's
``Rodas5PTableau``, given directly in the transformed variables): 8 stages, order 5 with an
embedded order 4 (the error estimate is the last stage, ``e = e_8``), L-stable and stiffly
accurate, dense output of order 4. It is not a W-method: it needs the exact Jacobian at the start of
every step, which the driver then evaluates at the end of every accepted step. Where the analytic
Jacobian is not exact (flank friction: its lever arms' dependence on the mesh phase is left out)
its order drops and its error estimate carries the Jacobian's error: use ROS34PW2 there. It costs about twice
a ROS34PW2 step and needs several times fewer steps from tolerance 1e-4 down (the contact level's
impact transient, docs/accuracy.md). Selected by the structural parameter ``solver.method``.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from spurdiff.numerics import gj_inverse, lu_factor, lu_solve, mat_mul   # noqa: F401 (lu_*: the W solves)

# Plain floats throughout (vectors are lists, matrices lists of rows), in the compiled kernel's order of
# operations: the same bits as mesh_kernel.c, and no numpy at run time (an FMU carries none).


class RosenbrockTableau(NamedTuple):
    """Coefficients of a Rosenbrock(-W) method in the form of Hairer-Wanner: ``alpha``,
    ``Gamma`` (lower triangular, constant diagonal ``gamma``), weights ``b`` and the embedded
    ``bhat``, and the dense output ``y(t + theta h) = y + sum_i B_i(theta) k_i`` with
    ``B_i(theta) = sum_j binterp[i][j] theta^(j+1)`` (three or four powers); matrices as lists of rows."""

    name: str
    gamma: float
    alpha: list
    Gamma: list
    b: list
    bhat: list
    binterp: list
    order: int
    embedded_order: int


ROS34PW2 = RosenbrockTableau(
    name="ROS34PW2",
    gamma=4.3586652150845900e-01,
    alpha=[
        [0.0, 0.0, 0.0, 0.0],
        [8.7173304301691801e-01, 0.0, 0.0, 0.0],
        [8.4457060015369423e-01, -1.1299064236484185e-01, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
    ],
    Gamma=[
        [4.3586652150845900e-01, 0.0, 0.0, 0.0],
        [-8.7173304301691801e-01, 4.3586652150845900e-01, 0.0, 0.0],
        [-9.0338057013044082e-01, 5.4180672388095326e-02, 4.3586652150845900e-01, 0.0],
        [2.4212380706095346e-01, -1.2232505839045147e+00, 5.4526025533510214e-01, 4.3586652150845900e-01],
    ],
    b=[2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, 4.3586652150845900e-01],
    bhat=[3.7810903145819369e-01, -9.6042292212423178e-02, 5.0000000000000000e-01, 2.1793326075422950e-01],
    binterp=[
        [1.0564298455794094, -1.3864882699759573, 0.5721822314575016],
        [2.296429974281067, -8.262611700275677, 4.742931142090097],
        [-1.307599564525376, 7.250979895056055, -4.398120075195578],
        [-1.045260255335102, 2.398120075195581, -0.9169932983520199],
    ],
    order=3,
    embedded_order=2,
)


class Transformed(NamedTuple):
    """A tableau in the transformed variables ``u_i = sum_j Gamma_ij k_j``: ``a_rows`` (stage
    arguments, row i with i entries), ``c_rows`` (strictly lower, stage right-hand sides), ``m``
    (solution weights), ``e`` (error weights), ``dmid`` (dense output at theta = 1/2); lists of floats.
    The dense output ``y + sum_j d_j(theta) u_j`` with ``d = B(theta) Ginv``, ``B_i = sum_p
    binterp[i][p] theta^(p+1)`` (Ginv the identity for a method given in the transformed variables).
    ``w_method``: the order holds for any Jacobian (else the driver needs J at every step's start);
    ``err_exp``: the step-size controller's exponent, -1 / (embedded order + 1); ``dquarter``:
    the dense output's weights at theta = 1/4 and 3/4 (rows) for the five-point loss quadrature of
    a method of order above 3 (None: the three-point one); ``dpoly``: the dense output as
    ``d_j(theta) = sum_p dpoly[p][j] theta^(p+1)``, four rows (a three-power output's fourth row 0):
    ``sum_i binterp[i][p] Ginv[i][j]`` summed in the order of i."""

    gamma: float
    stages: int
    a_rows: list
    c_rows: list
    m: list
    e: list
    dmid: list
    Ginv: list
    binterp: list
    embedded_order: int
    name: str = ""
    order: int = 0
    w_method: bool = True
    err_exp: float = -1.0 / 3.0
    dquarter: list = None
    dpoly: list = None


def transform(tab: RosenbrockTableau) -> Transformed:
    """A Hairer-Wanner tableau in the transformed variables (a W-method: ROS34PW2)."""
    G = [[float(v) for v in row] for row in tab.Gamma]
    Ginv = gj_inverse([list(row) for row in G])
    s = len(G)
    a = mat_mul([[float(v) for v in row] for row in tab.alpha], Ginv)
    c = [[(1.0 / G[i][i] if i == j else 0.0) - Ginv[i][j] for j in range(s)] for i in range(s)]
    m, e = mat_mul([[float(v) for v in tab.b], [float(b) - float(bh) for b, bh in zip(tab.b, tab.bhat)]], Ginv)
    return _finish(tab.name, tab.gamma, a, c, m, e, Ginv, tab.binterp, tab.order, tab.embedded_order, True)


def _finish(name, gamma, a, c, m, e, Ginv, binterp, order, embedded_order, w_method) -> Transformed:
    s = len(m)
    bl = [[float(v) for v in row] for row in binterp]
    tr = Transformed(gamma, s, [list(a[i][:i]) for i in range(s)], [list(c[i][:i]) for i in range(s)], list(m),
                     list(e), None, Ginv, bl, embedded_order, name=name, order=order,
                     w_method=w_method, err_exp=-1.0 / (embedded_order + 1))
    tr = tr._replace(dmid=dense_weights(0.5, tr))
    if order > 3:
        tr = tr._replace(dquarter=[dense_weights(0.25, tr), dense_weights(0.75, tr)])
    dpoly = mat_mul([list(col) for col in zip(*bl)], Ginv)     # binterp^T Ginv, summed in the order of i
    dpoly += [[0.0] * s for _ in range(4 - len(dpoly))]
    return tr._replace(dpoly=dpoly)


def dense_weights(theta: float, tr: "Transformed | None" = None) -> list:
    """Weights d_i with y(t + theta h) = y + sum_i d_i u_i (transformed stages)."""
    tr = tr or METHOD
    powers = [[theta], [theta ** 2], [theta ** 3], [theta ** 4]][:len(tr.binterp[0])]
    Bt = [r[0] for r in mat_mul(tr.binterp, powers)]
    return mat_mul([Bt], tr.Ginv)[0]


def _rodas5p() -> Transformed:
    """RODAS5P (Steinebach 2023) in the transformed variables: ``a`` and ``c`` as published
    (``c`` with our sign: ``W u_i = f(Y_i) + sum_j c_ij / h u_j``, ``W = I/(gamma h) - J``);
    stages 7 and 8 evaluate at ``Y_6 + u_6`` and ``Y_6 + u_6 + u_7``, the solution is
    ``Y_6 + u_6 + u_7 + u_8`` (stiffly accurate) and the error estimate ``u_8``. Dense output
    ``y0 (1 - t) + t (y1 + (1 - t)(H1 u + t (H2 u + t H3 u)))`` expanded in powers of t."""
    a5 = [-7.502846399306121, 2.561846144803919, -11.627539656261098, -0.18268767659942256, 0.030198172008377946]
    a_low = [[], [3.0], [2.849394379747939, 0.45842242204463923],
             [-6.954028509809101, 2.489845061869568, -10.358996098473584],
             [2.8029986275628964, 0.5072464736228206, -0.3988312541770524, -0.04721187230404641],
             a5, [*a5, 1.0], [*a5, 1.0, 1.0]]
    c_low = [[], [-14.155112264123755], [-17.97296035885952, -2.859693295451294],
             [147.12150275711716, -1.41221402718213, 71.68940251302358],
             [165.43517024871676, -0.4592823456491126, 42.90938336958603, -5.961986721573306],
             [24.854864614690072, -3.0009227002832186, 47.4931110020768, 5.5814197821558125, -0.6610691825249471],
             [30.91273214028599, -3.1208243349937974, 77.79954646070892, 34.28646028294783, -19.097331116725623,
              -28.087943162872662],
             [37.80277123390563, -3.2571969029072276, 112.26918849496327, 66.9347231244047, -40.06618937091002,
              -54.66780262877968, -9.48861652309627]]
    a = [row + [0.0] * (8 - len(row)) for row in a_low]
    c = [row + [0.0] * (8 - len(row)) for row in c_low]
    m = [*a5, 1.0, 1.0, 1.0]
    e = [0.0] * 7 + [1.0]
    H = [
        [25.948786856663858, -2.5579724845846235, 10.433815404888879, -2.3679251022685204, 0.524948541321073,
         1.1241088310450404, 0.4272876194431874, -0.17202221070155493],
        [-9.91568850695171, -0.9689944594115154, 3.0438037242978453, -24.495224566215796, 20.176138334709044,
         15.98066361424651, -6.789040303419874, -6.710236069923372],
        [11.419903575922262, 2.8879645146136994, 72.92137995996029, 80.12511834622643, -52.072871366152654,
         -59.78993625266729, -0.15582684282751913, 4.883087185713722]]
    binterp = [[m[i] + H[0][i], H[1][i] - H[0][i], H[2][i] - H[1][i], -H[2][i]] for i in range(8)]
    eye = [[1.0 if i == j else 0.0 for j in range(8)] for i in range(8)]
    return _finish("RODAS5P", 0.21193756319429014, a, c, m, e, eye, binterp, 5, 4, False)


METHOD = transform(ROS34PW2)
RODAS5P = _rodas5p()
METHODS = {"ros34pw2": METHOD, "rodas5p": RODAS5P}   # solver.method
SMAX = 8                                              # the most stages (the compiled kernel's arrays)
GAMMA = METHOD.gamma
STAGES = METHOD.stages
ORDER, EMBEDDED_ORDER = ROS34PW2.order, ROS34PW2.embedded_order


def zeros(n: int, m: int | None = None) -> list:
    """A vector of n zeros, or an n x m matrix of them (rows)."""
    return [0.0] * n if m is None else [[0.0] * m for _ in range(n)]


class RosenbrockW:
    """One step of a Rosenbrock(-W) method (default ROS34PW2; RODAS5P) on a system given by ``evaluate(y, f_out, J_out)``.

    Vectors are lists of floats, the Jacobian ``J`` a list of rows. ``evaluate`` fills ``f_out``
    (and ``J_out`` if not None) in place and returns nothing; it must not keep references to ``y``.
    ``y_new``, ``err`` and the stages ``U`` are new lists at each step.

    ``split``: (positions, velocities), index tuples of a second-order system whose position rows
    of J are constant and zero in the position columns (``x_p' = B x_v``, the mesh model's kinematic
    rows): W is then solved through the Schur complement on the velocities (:func:`split_factor`,
    :func:`split_solve`, what the compiled kernel does); None: a general LU (:func:`lu_factor`).
    """

    def __init__(self, n: int, evaluate, method: Transformed = METHOD, split: tuple | None = None):
        self.method = method
        self.n = n
        self.split = split
        self.evaluate = evaluate
        self.J = zeros(n, n)
        self.U = [zeros(n) for _ in range(method.stages)]
        self.F = zeros(n)
        self.y_new = zeros(n)
        self.err = zeros(n)
        self.lu = self.piv = None
        self.lu_h = 0.0           # the step size the factored W = I/(gamma h) - J is for; 0: none
        self.n_factorizations = 0

    def step(self, y, f0, h: float) -> bool:
        """Attempt a step of size h from y (with f0 = f(y) and self.J, an approximation of J(y),
        already filled: a W-method keeps its order for any J). W is factored unless the last
        factorization was for the same J (``lu_h`` is reset to 0 whenever J changes) and the same h.

        Sets ``y_new`` and ``err`` (the raw error estimate vector). Returns False if the linear
        system is singular or a stage is not finite.
        """
        U, F = self.U, self.F
        tr = self.method
        if h != self.lu_h:
            self.lu_h = 0.0
            self.n_factorizations += 1
            if self.split is not None:
                self.lu, self.piv = split_factor(self.J, tr.gamma * h, *self.split), None
            else:
                d = 1.0 / (tr.gamma * h)
                n = self.n
                # (I * d - J, entry by entry as the kernel forms it)
                self.lu, self.piv = lu_factor([[(1.0 if i == j else 0.0) * d - Ji[j] for j in range(n)]
                                               for i, Ji in enumerate(self.J)])
            if self.lu is None:
                return False
            self.lu_h = h
        lu, piv = self.lu, self.piv
        solve = lu_solve if piv is not None else split_solve
        U[0] = solve(lu, piv, f0)
        ih = 1.0 / h
        for i in range(1, tr.stages):
            Ys = [s + v for s, v in zip(combine(tr.a_rows[i], U), y)]
            self.evaluate(Ys, F, None)
            U[i] = solve(lu, piv, [r * ih + v for r, v in zip(combine(tr.c_rows[i], U), F)])
        yn = self.y_new = [s + v for s, v in zip(combine(tr.m, U), y)]
        self.err = combine(tr.e, U)
        for v in yn:
            if not math.isfinite(v):
                return False
        return True

    def dense_at(self, weights: list, y) -> list:
        """Dense output of the last step with the weights of one point (``dquarter``'s rows)."""
        return [s + v for s, v in zip(combine(weights, self.U), y)]

    def midpoint(self, y) -> list:
        """Dense output at the middle of the last step (ROS34PW2: order 3 with the exact Jacobian, 2 as a
        W-method; RODAS5P 4)."""
        return self.dense_at(self.method.dmid, y)


def split_factor(J: list, e: float, pos: tuple, vel: tuple) -> tuple | None:
    """The factors of ``W = I/e - J`` (``e = gamma h``) for a second-order system (rows ``pos`` of
    ``J``: ``B`` in the columns ``vel``, 0 in the columns ``pos``): ``W x = r`` is ``x_v = S^-1 (r_v +
    e J_vp r_p)``, ``x_p = e (r_p + B x_v)`` with the Schur complement ``S = I/e - J_vv - e J_vp B``
    (m x m, m = len(vel)), inverted explicitly by Gauss-Jordan with
    partial pivoting (:func:`gj_inverse`; a solve is then three small matrix-vector products whose
    rows are independent, where an 8 x 8 triangular solve is a chain of dependent operations). Plain
    floats in a fixed order of operations, the compiled kernel's ``split_factor`` operation for
    operation. Returns (S^-1, J_vp, B, e, pos, vel), or None for an exactly singular S."""
    m = len(vel)
    d = 1.0 / e
    Jvp = [[J[v][p] for p in pos] for v in vel]
    B = [[J[p][v] for v in vel] for p in pos]
    S = []
    for i in range(m):
        Ji, Jvpi = J[vel[i]], Jvp[i]
        row = []
        for j in range(m):
            jb = Jvpi[0] * B[0][j]
            for k in range(1, m):
                jb += Jvpi[k] * B[k][j]
            row.append(((d if i == j else 0.0) - Ji[vel[j]]) - e * jb)
        S.append(row)
    Si = gj_inverse(S)
    return None if Si is None else (Si, Jvp, B, e, pos, vel)


def split_solve(F: tuple, _piv, r: list) -> list:
    """x with ``W x = r`` from :func:`split_factor`'s factors (the kernel's ``split_solve``, the
    same order)."""
    Si, Jvp, B, e, pos, vel = F
    m = len(vel)
    rp = [r[p] for p in pos]
    t = [r[vel[i]] + e * _dot(Jvp[i], rp) for i in range(m)]
    x = [0.0] * len(r)
    xv = [_dot(Si[i], t) for i in range(m)]
    for i in range(m):
        x[vel[i]] = xv[i]
        x[pos[i]] = e * (rp[i] + _dot(B[i], xv))
    return x


def _dot(a: list, x: list) -> float:
    """``a . x`` summed from the first term on (the kernel's order)."""
    s = a[0] * x[0]
    for k in range(1, len(x)):
        s += a[k] * x[k]
    return s


def combine(coef: list, U: list) -> list:
    """``sum_k coef[k] U[k]`` (a new list), summed in the order of k entry by entry, so that the
    compiled kernel, which sums in the same order, gives the same bits."""
    c0 = coef[0]
    out = [u * c0 for u in U[0]]
    for k in range(1, len(coef)):
        ck = coef[k]
        out = [o + u * ck for o, u in zip(out, U[k])]
    return out


def error_norm(err, y, y_new, atol, rtol: float) -> float:
    """RMS norm of err / (atol + rtol max(|y|, |y_new|)) (Hairer-Wanner), summed in index order."""
    ss = 0.0
    for e, a, b, at in zip(err, y, y_new, atol):
        a, b = abs(a), abs(b)
        q = e / ((b if b > a or b != b else a) * rtol + at)    # (the larger, NaN kept, as numpy.maximum)
        ss += q * q
    return math.sqrt(ss / len(err))


def new_step_size(h: float, err: float, rejected: bool, exponent: float = METHOD.err_exp) -> float:
    """Elementary controller h_new = h * clamp(0.9 err^exponent, 0.2, 5) (1 after a rejection);
    the exponent -1 / (embedded order + 1): -1/3 for ROS34PW2, -1/5 for RODAS5P."""
    if err <= 0.0:
        fac = 5.0
    else:
        fac = 0.9 * err ** exponent
    fac = min(5.0 if not rejected else 1.0, max(0.2, fac))
    return h * fac
