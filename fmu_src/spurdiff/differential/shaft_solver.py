"""The implicit sub-step of the shaft-owning differential (:mod:`spurdiff.differential.shafts`): the sun torques
``T = (T_L, T_R)``, constant over a sub-step ``hs``, that solve the backward-Euler torque-twist law
of both half-shafts (model and scheme in :mod:`spurdiff.differential.shafts`)::

    T + c (theta_0 + dtheta(T)) + d dtheta(T) / hs = 0,   dtheta(T) = dphi_s(T) - dphi_w(-T)

where ``dphi_s(T)`` is the inner model's (rigid, compliant or contact) sun-angle change over the
sub-step with the torques ``T`` held. The inner model's response is affine in ``T`` within a
friction/contact mode (exactly so at rigid), and so is the wheel side's: a Newton iteration with a
finite-difference Jacobian, refreshed by Broyden updates and recomputed when a mode change slows
it, converges in two corrections in the usual case (three inner steps per sub-step).

:class:`ShaftSolver` holds the solve (the residual, its Jacobian, the Newton/Broyden iteration,
the halving of a sub-step that does not converge) as methods of the model, which
:class:`spurdiff.differential.shafts.ShaftedDifferential` inherits: they read and update its state (twists,
torques, work ledger, the Jacobian cache ``jac``) and step its inner model.
"""
from __future__ import annotations

import math

from spurdiff.errors import StepError
from spurdiff.differential.shaft_params import WheelSurrogate


class _NotConverged(StepError):
    """The sub-step's Newton iteration did not converge (the step is then halved)."""


class ShaftSolver:
    """The sub-step solve of :class:`spurdiff.differential.shafts.ShaftedDifferential` (its base class)."""

    def _eval(self, snap: dict, t: float, hs: float, TL: float, TR: float,
              phiL0: float, phiR0: float, dwL: float, dwR: float, sL: float = 0.0,
              sR: float = 0.0, restore: bool = True) -> tuple[float, float, float, float]:
        """Residuals (N m) and twist changes for sun torques (TL, TR) held over one sub-step; the
        wheel-side angle changes are dwL + sL (-TL) and dwR + sR (-TR) (affine in the torque).
        restore False: the inner model is in the state ``snap`` already (not restored)."""
        inner = self.inner
        if restore:
            inner.set_state(snap)
        inner.tau_L, inner.tau_R = TL, TR
        inner.do_step(t, hs)
        self.n_evals += 1
        left, right = self._lr
        dthL = inner.phi_L - phiL0 - (dwL - sL * TL)
        dthR = inner.phi_R - phiR0 - (dwR - sR * TR)
        rL = TL + left.c * (self.theta_L + dthL) + left.d * dthL / hs
        rR = TR + right.c * (self.theta_R + dthR) + right.d * dthR / hs
        return rL, rR, dthL, dthR

    def _jacobian(self, snap, t, hs, TL, TR, r, args, mode) -> list[float]:
        """Finite-difference Jacobian of the residuals at (TL, TR) on the piece (mode) of the point
        (the response is affine within a mode of the rigid model): each column from a difference
        of 1e-3 relative (smaller ones lose digits to the absolute angles), on whichever side
        stays on the point's piece, down to 1e-7 relative near a stick-slip kink."""
        cols = []
        base = 1e-3 * (1.0 + abs(TL) + abs(TR))
        for j in (0, 1):
            for dT in (base, -base, 1e-2 * base, -1e-2 * base, 1e-4 * base, -1e-4 * base):
                e = self._eval(snap, t, hs, TL + (dT if j == 0 else 0.0), TR + (dT if j == 1 else 0.0), *args)
                if self._mode(snap) == mode:
                    break
            cols.append(((e[0] - r[0]) / dT, (e[1] - r[1]) / dT))
        self.n_jacobians += 1
        return [cols[0][0], cols[1][0], cols[0][1], cols[1][1]]

    def _mode(self, snap: dict) -> str:
        """The inner model's mode over the last evaluated sub-step: the slip direction at its end
        and whether it switched inside (a rigid model; the mesh models have one key)."""
        inner = self.inner
        sd = getattr(inner, "slip_dir", None)
        if sd is None:
            return "m"
        switched = inner.n_mode_switches != snap.get("n_mode_switches", inner.n_mode_switches)
        # the key f"{sd:+.0f}" plus "x" if switched; the usual directions without formatting
        key = "+1" if sd == 1.0 else ("-1" if sd == -1.0 else f"{sd:+.0f}")
        return key + "x" if switched else key

    def _advice(self) -> str:
        """What to do about a sub-step that does not converge. A mesh level's response carries its
        impacts through the backlash and its integrator's error: a smaller sub-step helps. The rigid
        level's response is piecewise affine in the sun torques, exact at any sub-step: a smaller one
        does not help, only a jump in the response (no root) stops it (docs/locking-law.md)."""
        if self._rigid:
            return ("the rigid level's response to the sun torques jumps here (no root); a smaller "
                    "shafts.h_max does not help")
        return "reduce shafts.h_max"

    def _substep(self, t: float, hs: float, wL: float, wR: float, xL: tuple, xR: tuple,
                 mL: WheelSurrogate, mR: WheelSurrogate, snap: dict) -> tuple[float, float, float, float]:
        """One sub-step from the inner model's state ``snap`` (its present state); wL, wR the
        wheel-side speeds at the communication point, xL, xR the wheel sides' deviations (dw, q)
        from it at the start of the sub-step (updated in place)."""
        inner = self.inner
        phiL0, phiR0 = inner.phi_L, inner.phi_R
        # wheel-side angle change, trapezoidal in the midpoint rule's speeds: affine in its torque
        pL = mL.midpoint(hs, xL)
        pR = mR.midpoint(hs, xR)
        a = 0.5 * hs
        args = (phiL0, phiR0, hs * wL + a * (xL[0] + pL[0]), hs * wR + a * (xR[0] + pR[0]),
                a * pL[1], a * pR[1])
        sp = self.shafts
        # The Jacobian J = I + diag(k) (S + diag(s)) with k = c + d / hs, s the wheel sides' angle
        # change per N m (known) and S the inner model's sun-angle change per N m, S = hs^2 S_n with
        # S_n constant within a mode of the rigid model (constant accelerations). S_n is kept per
        # mode (self.jac: mode key -> S_n, refreshed by Broyden updates and finite differences), so
        # the usual sub-step needs the first evaluation, one correction and its check.
        kL, kR = sp.left.c + sp.left.d / hs, sp.right.c + sp.right.d / hs
        sL, sR, h2 = args[4], args[5], hs * hs

        def J_of(Sn):
            return [1.0 + kL * (Sn[0] * h2 + sL), kL * Sn[1] * h2, kR * Sn[2] * h2, 1.0 + kR * (Sn[3] * h2 + sR)]

        def Sn_of(J):
            return [((J[0] - 1.0) / kL - sL) / h2, J[1] / kL / h2, J[2] / kR / h2, ((J[3] - 1.0) / kR - sR) / h2]

        cache = self.jac
        TL, TR = self.T_L, self.T_R
        # the first evaluation starts from the present state: a rigid inner model is not restored
        # (its set_state of its own get_state changes nothing)
        r = self._eval(snap, t, hs, TL, TR, *args, restore=not self._rigid)
        mode = self._mode(snap)
        J = J_of(cache[mode]) if mode in cache else None
        # the torque-twist law to 1e-10 relative: the result is then a smooth function of the
        # inputs down to that level (another host feeding the same inputs to the last bits gets the
        # same trajectory to 1e-9; at 1e-8 the iteration count flips and it does not)
        scale = 1e-10 * (1.0 + abs(TL) + abs(TR))
        fresh = switched = updated = False
        for it in range(40):
            if abs(r[0]) + abs(r[1]) <= scale:
                break
            if J is None or (it >= 2 and not fresh):
                J = self._jacobian(snap, t, hs, TL, TR, r, args, mode)
                fresh, updated = True, False
            det = J[0] * J[3] - J[1] * J[2]
            if not (det != 0.0 and math.isfinite(det)):
                # singular as differenced: no solution to step to. A kept or Broyden-updated J
                # (secants at the mesh model's noise floor, steps of 1e-17 N m against residual
                # jumps of 1e-8, can blow it up) is replaced by a fresh difference instead
                if fresh and not updated:
                    raise StepError("shafts: the sun-torque Jacobian is singular")
                J = None
                continue
            dTL = -(J[3] * r[0] - J[1] * r[1]) / det
            dTR = -(J[0] * r[1] - J[2] * r[0]) / det
            if it >= 8:   # piecewise-affine residual near a mode switch: damp the correction
                dTL *= 0.5
                dTR *= 0.5
            TL, TR = TL + dTL, TR + dTR
            r_new = self._eval(snap, t, hs, TL, TR, *args)
            mode_new = self._mode(snap)
            if mode_new != mode and mode_new in cache and not switched:
                # the first switch to another piece of the piecewise-affine response: its kept
                # Jacobian (later switches: the secant across the kink, which does not cycle)
                J = J_of(cache[mode_new])
                switched = True
            else:
                # Broyden update: J += (dr - J dT) dT' / |dT|^2 (the secant through both points)
                n2 = dTL * dTL + dTR * dTR
                if n2 > 0.0:
                    yL = r_new[0] - r[0] - (J[0] * dTL + J[1] * dTR)
                    yR = r_new[1] - r[1] - (J[2] * dTL + J[3] * dTR)
                    J = [J[0] + yL * dTL / n2, J[1] + yL * dTR / n2, J[2] + yR * dTL / n2, J[3] + yR * dTR / n2]
                    updated = True
            mode = mode_new
            r = r_new
            scale = 1e-10 * (1.0 + abs(TL) + abs(TR))
        else:
            # a piecewise-affine residual (a stick-slip switch inside the sub-step: a kink at the
            # solution) can stall Newton above the tight tolerance, and a mesh model's response
            # carries its integrator's error: accept 1e-6 relative (the torque-twist law to 0.1 mN m
            # at 100 N m; the energy ledger stays exact, it books the torques actually applied) or
            # ten times the mesh tolerance, no more
            if not abs(r[0]) + abs(r[1]) <= self._accept * (1.0 + abs(TL) + abs(TR)):
                raise _NotConverged(f"shafts: the implicit sub-step at t = {t:.6g} s did not converge (residual "
                                    f"{abs(r[0]) + abs(r[1]):.3g} N m, sub-step halved 6 times); {self._advice()}")
        if J is not None:
            cache[mode] = Sn_of(J)
        # the inner model now holds the converged sub-step (the last evaluation)
        dthL, dthR = r[2], r[3]
        sp = self.shafts
        self.work_suns += TL * (inner.phi_L - phiL0) + TR * (inner.phi_R - phiR0)
        # shaft torque on the wheel is -T; the wheel side moves by the model's angle change
        self.work_wheels += TL * (args[2] - args[4] * TL) + TR * (args[3] - args[5] * TR)
        xL[0], xL[1] = pL[0] - pL[1] * TL, pL[2] - pL[3] * TL
        xR[0], xR[1] = pR[0] - pR[1] * TR, pR[2] - pR[3] * TR
        self.shaft_loss += (0.5 * sp.left.c * dthL * dthL + sp.left.d * dthL * dthL / hs
                            + 0.5 * sp.right.c * dthR * dthR + sp.right.d * dthR * dthR / hs)
        self.theta_L += dthL
        self.theta_R += dthR
        self.T_L, self.T_R = TL, TR
        return TL, TR, dthL, dthR

    def _advance(self, t: float, hs: float, wL: float, wR: float, xL: list, xR: list, acc: list,
                 depth: int, snap: dict | None = None) -> None:
        """One sub-step; where its Newton does not converge (a mesh model's impacts through the
        backlash make its response non-smooth in the torques) two halves instead, down to 1/64.
        ``snap``: the inner model's present state if the caller has it (else taken here)."""
        if snap is None:
            snap = self.inner.get_state()
        jac = {k: list(v) for k, v in self.jac.items()}
        try:
            TL, TR, _, _ = self._substep(t, hs, wL, wR, xL, xR, self.wheelL_model, self.wheelR_model, snap)
        except _NotConverged:
            if depth >= 6:
                raise
            self.inner.set_state(snap)
            self.jac = jac
            self.n_halvings += 1
            self._advance(t, 0.5 * hs, wL, wR, xL, xR, acc, depth + 1)
            self._advance(t + 0.5 * hs, 0.5 * hs, wL, wR, xL, xR, acc, depth + 1)
            return
        acc[0] += TL * hs
        acc[1] += TR * hs
        self.n_substeps += 1
