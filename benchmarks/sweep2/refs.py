"""Closed-form / shooting references for planar elastica problems (used by make.py).

Planar inextensible, unshearable Kirchhoff rod of length L, bending stiffness EI,
clamped at s = 0 with tangent angle theta0 (in the plane basis e1, e2), loaded by a
dead tip force P = (Px, Py), a dead distributed force w = (wx, wy) per unit length
and a tip moment M0 (about e1 x e2).

    x' = cos th, y' = sin th, EI th' = m, m' = -(cos th Fy(s) - sin th Fx(s)),
    F(s) = P + w (L - s)   (resultant of the loads beyond s),  m(L) = M0.

Solved by shooting on m(0) (solve_ivp, rtol 1e-12) with continuation in the load
factor from 0, i.e. the branch reached along the loading path from rest.
"""
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, newton
from scipy.special import ellipk, ellipe


def _integrate(m0, L, EI, th0, P, w, M0, lam):
    Px, Py = lam * P[0], lam * P[1]
    wx, wy = lam * w[0], lam * w[1]

    def f(s, y):
        x, yy, th, m = y
        Fx = Px + wx * (L - s)
        Fy = Py + wy * (L - s)
        return [math.cos(th), math.sin(th), m / EI, -(math.cos(th) * Fy - math.sin(th) * Fx)]

    sol = solve_ivp(f, (0, L), [0.0, 0.0, th0, m0], rtol=1e-12, atol=1e-15, method="DOP853")
    return sol.y[:, -1]


def _root(res, m0):
    """root of res near m0: secant, polished and checked by a bracket"""
    try:
        m = newton(res, m0, tol=1e-15 * max(abs(m0), 1e-300), maxiter=100)
    except RuntimeError:
        m = m0
    span = max(abs(m), 1e-300) * 1e-6
    for _ in range(1100):
        a, b = m - span, m + span
        if res(a) * res(b) <= 0:
            return brentq(res, a, b, xtol=1e-300, rtol=1e-15)
        span *= 2
    raise RuntimeError("no root near %g" % m0)


import functools


@functools.lru_cache(maxsize=None)
def elastica(L, EI, P=(0.0, 0.0), w=(0.0, 0.0), M0=0.0, th0=0.0, steps=64, start_guess=None):
    """Tip (x, y, theta) on the loading path. Returns dict."""
    m0 = 0.0
    for k in range(1, steps + 1):
        lam = k / steps
        res = lambda m: _integrate(m, L, EI, th0, P, w, M0, lam)[3] - lam * M0
        # linear predictor guess at first step
        if k == 1 and start_guess is not None:
            m0 = start_guess * lam
        m0 = _root(res, m0)
    x, y, th, m = _integrate(m0, L, EI, th0, P, w, M0, 1.0)
    return {"x": x, "y": y, "theta": th, "m0": m0, "mres": m - M0}


def column_postbuckling(L, EI, P):
    """Perfect clamped-free column, dead axial load P > Pcr: exact elliptic-integral
    elastica. Returns (axial tip position from the root along the original axis,
    lateral tip deflection, tip rotation)."""
    lamL = math.sqrt(P / EI) * L
    # lamL = K(k), k = sin(alpha/2); scipy ellipk takes m = k^2
    m = brentq(lambda m: ellipk(m) - lamL, 1e-16, 1 - 1e-16)
    k = math.sqrt(m)
    lam = lamL / L
    x_tip = (2 * ellipe(m) / ellipk(m) - 1) * L
    y_tip = 2 * k / lam
    alpha = 2 * math.asin(k)
    return x_tip, y_tip, alpha


@functools.lru_cache(maxsize=None)
def column_imperfect(L, EI, P, eps):
    """Clamped-free column, dead axial compression P along -e1 and a lateral dead
    force eps*P along +e2 at the tip: the branch the imperfection selects (deflection
    towards +e2). Newton on m(0) started from the perfect elastica (P > Pcr) or the
    linear beam-column solution (P < Pcr)."""
    Pcr = math.pi ** 2 * EI / (4 * L * L)
    if P > Pcr * 1.0001:
        _, y, _ = column_postbuckling(L, EI, P)
        m0 = P * y
    else:
        k = math.sqrt(P / EI)
        H = eps * P
        y = H / (P * k) * (math.tan(k * L) - k * L)
        m0 = H * L + P * y
    Pv = (-P, eps * P)
    res = lambda m: _integrate(m, L, EI, 0.0, Pv, (0, 0), 0.0, 1.0)[3]
    m0 = _root(res, m0)
    x, y, th, m = _integrate(m0, L, EI, 0.0, Pv, (0, 0), 0.0, 1.0)
    assert y > 0, "wrong branch"
    return {"x": x, "y": y, "theta": th, "m0": m0, "mres": m}


from scipy.integrate import solve_bvp  # noqa: E402


@functools.lru_cache(maxsize=None)
def elastica_bvp(L, EI, P=(0.0, 0.0), w=(0.0, 0.0), M0=0.0, th0=0.0, steps=50):
    """Same problem as elastica(), by collocation (solve_bvp) with continuation in
    the load factor, each step started from the previous solution (no branch
    jumping), then polished by shooting from its m(0) (local secant only)."""
    s = np.linspace(0, L, 401)
    Y = np.vstack([s * math.cos(th0), s * math.sin(th0), np.full_like(s, th0), np.zeros_like(s)])
    for k in range(1, steps + 1):
        lam = k / steps

        def f(ss, y, lam=lam):
            Fx = lam * (P[0] + w[0] * (L - ss))
            Fy = lam * (P[1] + w[1] * (L - ss))
            return np.vstack([np.cos(y[2]), np.sin(y[2]), y[3] / EI, -(np.cos(y[2]) * Fy - np.sin(y[2]) * Fx)])

        def bc(ya, yb, lam=lam):
            return np.array([ya[0], ya[1], ya[2] - th0, yb[3] - lam * M0])

        sol = solve_bvp(f, bc, s, Y, tol=1e-9, max_nodes=200000)
        if not sol.success:
            raise RuntimeError("bvp failed at lam=%g: %s" % (lam, sol.message))
        s, Y = sol.x, sol.y
    m0 = Y[3, 0]
    res = lambda m: _integrate(m, L, EI, th0, P, w, M0, 1.0)[3] - M0
    try:
        m1 = newton(res, m0, tol=1e-15 * max(abs(m0), 1e-300), maxiter=50)
        if abs(m1 - m0) < 1e-4 * max(abs(m0), 1e-12):
            m0 = m1
    except RuntimeError:
        pass
    x, y, th, m = _integrate(m0, L, EI, th0, P, w, M0, 1.0)
    return {"x": x, "y": y, "theta": th, "m0": m0, "mres": m - M0, "bvp_tip": [float(Y[0, -1]), float(Y[1, -1])]}
