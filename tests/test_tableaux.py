"""The one home of the Runge-Kutta coefficients (gearsweep.kernels.tableaux) and the artifact map
of the paper's Fig. 7.2 for four fifth-order methods (issue 28 item 6)."""

from __future__ import annotations

import math
from fractions import Fraction as Fr

import numpy as np
import pytest

from gearsweep.analysis import stability as st
from gearsweep.kernels import rk, tableaux
from gearsweep.kernels.floquet import floquet, mathieu_parameters, monodromy

FIFTH = tableaux.FIFTH_ORDER


def _order_conditions(t: tableaux.Tableau) -> dict[str, tuple[Fr, Fr]]:
    """The 17 rooted-tree conditions up to order 5: (sum, required value)."""
    A, b, c, s = t.A, t.b, t.c, t.stages

    def Av(v):
        return [sum((A[i][j] * v[j] for j in range(s)), Fr(0)) for i in range(s)]

    def dot(u, v):
        return sum((x * y for x, y in zip(u, v, strict=True)), Fr(0))

    def mul(u, v):
        return [x * y for x, y in zip(u, v, strict=True)]

    one = [Fr(1)] * s
    c2, c3 = mul(c, c), mul(mul(c, c), c)
    Ac, Ac2, Ac3 = Av(c), Av(c2), Av(c3)
    AAc = Av(Ac)
    return {
        "1": (dot(b, one), Fr(1)), "c": (dot(b, c), Fr(1, 2)),
        "c2": (dot(b, c2), Fr(1, 3)), "Ac": (dot(b, Ac), Fr(1, 6)),
        "c3": (dot(b, c3), Fr(1, 4)), "cAc": (dot(b, mul(c, Ac)), Fr(1, 8)),
        "Ac2": (dot(b, Ac2), Fr(1, 12)), "AAc": (dot(b, AAc), Fr(1, 24)),
        "c4": (dot(b, mul(c3, c)), Fr(1, 5)), "c2Ac": (dot(b, mul(c2, Ac)), Fr(1, 10)),
        "cAc2": (dot(b, mul(c, Ac2)), Fr(1, 15)), "cAAc": (dot(b, mul(c, AAc)), Fr(1, 30)),
        "(Ac)2": (dot(b, mul(Ac, Ac)), Fr(1, 20)), "Ac3": (dot(b, Ac3), Fr(1, 20)),
        "A(cAc)": (dot(b, Av(mul(c, Ac))), Fr(1, 40)), "AAc2": (dot(b, Av(Ac2)), Fr(1, 60)),
        "AAAc": (dot(b, Av(AAc)), Fr(1, 120)),
    }


@pytest.mark.parametrize("name", sorted(tableaux.TABLEAUX))
def test_tableau_has_its_order(name):
    """Every tableau satisfies the order conditions up to its order, exactly (so a mistyped
    coefficient fails), and the rows are strictly lower triangular."""
    t = tableaux.get(name)
    assert all(len(r) == i for i, r in enumerate(t.rows))
    n_trees = {4: 8, 5: 17}[t.order]
    conds = list(_order_conditions(t).items())[:n_trees]
    bad = [k for k, (got, want) in conds if got != want]
    assert not bad, f"{name}: order conditions {bad} fail"
    # and R(z) matches e^z to that order
    p = tableaux.stability_polynomial(name)
    assert list(p[:t.order + 1]) == [Fr(1, math.factorial(k)) for k in range(t.order + 1)]


def test_rk4_is_not_fifth_order():
    """The conditions can fail: RK4 misses the fifth-order ones."""
    conds = _order_conditions(tableaux.get("rk4"))
    assert conds["c4"][0] != conds["c4"][1]


def test_known_stability_facts():
    assert tableaux.stability_polynomial("rk5")[6] == Fr(1, 640)
    assert tableaux.stability_polynomial("fehlberg5")[6] == Fr(1, 2080)
    assert tableaux.stability_polynomial("cashkarp5")[6] == Fr(1, 800)
    assert tableaux.stability_polynomial("dopri5")[6] == Fr(1, 600)
    assert len(tableaux.stability_polynomial("dopri5")) == 7  # 7 stages, b7 = 0: degree 6
    assert tableaux.imaginary_stability_interval("rk4") == pytest.approx(2 * math.sqrt(2), 1e-9)
    assert tableaux.imaginary_stability_interval("rk5") == pytest.approx(0.8523, abs=1e-4)
    assert tableaux.imaginary_stability_interval("fehlberg5") == 0.0
    assert tableaux.imaginary_stability_interval("cashkarp5") == 0.0
    assert tableaux.real_stability_interval("rk4") == pytest.approx(2.7853, abs=1e-4)
    assert tableaux.real_stability_interval("dopri5") == pytest.approx(3.3066, abs=1e-4)


@pytest.mark.parametrize("name", sorted(tableaux.TABLEAUX))
def test_intervals_agree_with_the_ray_limits(name):
    """Two computations of the same limits: roots of the exact polynomial (tableaux) and the
    scan-and-bisect of analysis.stability along the real and imaginary rays."""
    assert st.ray_limit(name, np.pi) == pytest.approx(tableaux.real_stability_interval(name),
                                                      rel=1e-9)
    imag = tableaux.imaginary_stability_interval(name)
    assert st.ray_limit(name, np.pi / 2) == pytest.approx(imag, rel=1e-9, abs=1e-12)


def test_kernel_constants_come_from_the_tableau():
    """The unrolled kernel's constants are the tableau's (the module checks the zero pattern)."""
    t = tableaux.get("rk5")
    assert rk._RK5_A21 == float(t.A[1][0]) and rk._RK5_A54 == float(t.A[4][3])
    assert rk._RK5_N61 / rk._RK5_D6 == float(t.A[5][0])
    assert rk._RK5_B3 / rk._RK5_D == float(t.b[2])
    assert rk._RK4_B2 / rk._RK4_D == float(tableaux.get("rk4").b[1])


@pytest.mark.parametrize("method", ["rk4", "rk5"])
def test_generic_map_equals_the_kernel(method):
    """The generic explicit-RK monodromy of analysis.stability is the compiled kernel's map, to
    round-off, for the two kernel methods (so the other tableaux are integrated the same way)."""
    a = np.array([0.3, 1.2, 40.0, 7000.0])
    b = np.array([0.2, 0.5, 6.7, 1160.0])
    g = np.array([0.0, 0.01, 0.3, 36.0])
    for S in (64, 200):
        Mk = monodromy(a, b, g, S, method=method)
        Mg = st.tableau_monodromy(a, b, g, S, method)
        ok = np.isfinite(Mk).all(axis=(1, 2))
        scale = np.abs(Mk[ok]).max(axis=(1, 2), keepdims=True)
        np.testing.assert_allclose(Mg[ok] / scale, Mk[ok] / scale, atol=1e-9)


def test_artifact_map_on_the_rig():
    """All four fifth-order methods flag a low-speed region at 200 steps per mesh period on the
    rig although the equation is stable there, and none at 2048; the flagged region lies below
    the guard rail's speed (frozen coefficients at k0 + k1) of each method."""
    speed = np.array([120.0, 150.0, 300.0, 1500.0])
    c = np.array([0.0, 5500.0])
    am = st.artifact_map(speed, c, k0=1073e6, k1=179e6, mass=0.1527, teeth=48,
                         steps_per_period=(200,))
    assert am["flag"][:, 0, :, 0].all()  # 120 rpm: flagged by every method, with and without c
    assert not am["flag"][:, 0, :, -1].any()  # 1500 rpm: nowhere
    fine = st.artifact_map(speed[:2], c, k0=1073e6, k1=179e6, mass=0.1527, teeth=48,
                           methods=("rk5",), steps_per_period=(2048,))
    assert not fine["flag"].any()
    # Every flagged speed lies below the method's guard speed, 60 omega_n / (teeth S (h
    # omega_n)*): frozen coefficients at k_max = k0 + k1, (h omega_n)* from step_limit_hw at
    # that damping ratio (infinite undamped for the tableaux with no imaginary-axis interval).
    # With c = 5500 N s/m the highest flagged speed is 160-170 rpm against guards of 181-189:
    # a map or a guard 10 % off fails. The equation itself is stable at every one of these
    # speeds (Floquet, converged): what is flagged is the integrator's.
    k0, k1, m, teeth, S = 1073e6, 179e6, 0.1527, 48, 200
    dense = np.linspace(60.0, 400.0, 35)
    am = st.artifact_map(dense, c, k0=k0, k1=k1, mass=m, teeth=teeth, steps_per_period=(S,))
    wn = math.sqrt((k0 + k1) / m)
    zeta = c / (2.0 * math.sqrt((k0 + k1) * m))
    for im, method in enumerate(am["methods"]):
        with np.errstate(divide="ignore"):
            guard = 60.0 * wn / (teeth * S * st.step_limit_hw(method, zeta))  # rpm, per c
        highest = np.where(am["flag"][im, 0], dense, -np.inf).max(axis=-1)
        assert np.all(highest <= guard), (method, highest, guard)
        assert 150.0 <= highest[1] < guard[1], (method, highest[1])  # damped: a region below
    exact = floquet(*mathieu_parameters(k0, k1, m, c[1], teeth * dense / 60.0))
    assert exact.converged.all() and not exact.unstable.any()


def test_reproduces_paper_logic():
    damping = np.array([0.0, 1000.0, 5500.0])
    edges = np.array([[400.0, 250.0, 200.0],     # shrinks, 200 at 5.5: yes
                      [400.0, 250.0, 300.0],     # grows with damping: no
                      [np.nan, np.nan, np.nan],  # nothing flagged: no
                      [400.0, 250.0, 100.0]])    # edge far from 200 rpm: no
    np.testing.assert_array_equal(st.reproduces_paper(edges, damping),
                                  [True, False, False, False])
