"""Independent flexible reference: the paper's plate load case in Exudyn's reduced-order
floating frame of reference formulation, stored in flexfmu/data/references/exudyn_plate/trajectory.csv by
generate.py beside it (Exudyn is not needed here).

Same input in both codes: the coarse plate paper_plate((20, 2, 1)) (M, K, nodes), its first ten flexible
modes (Exudyn computes its own; generate.py checks they are flexfmu's), 5% modal damping; 50 N along global
[1, 0, 1]/sqrt(2) at (-0.5, 0, 0.01) m as a 0.01 s half-sine pulse, free flight to 1 s.  Exudyn applies the
load at the deformed node position; so does flexfmu with deformed_load_arm=True.  Both body frames are the
linearised mean axes (flexible modes M-orthogonal to the rigid ones), so omega (body frame) and the
elastic displacement Psi q (body frame) are comparable directly.

`pytest -s` prints the numbers.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.plate import LOAD_POINT, X_RANGE, Y_RANGE, Z_RANGE, paper_plate
from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator, half_sine_pulse
from flexfmu.studies.references import reference_path

from error_bounds import gamma

REFERENCE = reference_path("exudyn_plate")
FORCE = 50.0 * np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)
PULSE = 0.01
DT = 1e-4
EVERY = 10                                   # records every 1 ms, the reference's grid
FAR_POINT = np.array([0.5, 0.0, 0.01])


def read_reference(path=REFERENCE):
    meta, header, rows = {}, None, []
    with open(path) as f:
        for line in f:
            if line.startswith("#"):
                key, _, value = line[1:].partition(":")
                meta[key.strip()] = value.strip()
            elif header is None:
                header = line.strip().split(",")
            else:
                rows.append([float(v) for v in line.split(",")])
    data = np.array(rows)
    return meta, {name: data[:, k] for k, name in enumerate(header)}


def cols(ref, prefix, names="xyz"):
    return np.column_stack([ref[f"{prefix}{c}"] for c in names])


@pytest.fixture(scope="module")
def runs():
    meta, ref = read_reference()
    plate = paper_plate((20, 2, 1))
    mb = modal_basis(plate, 10, 0.05)
    load = PointLoad(LOAD_POINT, half_sine_pulse(FORCE, PULSE))
    nodes = {"load": plate.points["load"],
             "far": int(np.argmin(np.linalg.norm(plate.nodes - FAR_POINT, axis=1)))}
    out = {}
    for arm in (True, False):
        integ = ReframeIntegrator(plate, mb, scheme="consistent", deformed_load_arm=arm)
        r = integ.run(1.0, DT, load, every=EVERY)
        u = {k: r.q @ mb.flexible[3 * n:3 * n + 3].T for k, n in nodes.items()}   # body frame, elastic
        out[arm] = (r, u)
    return meta, ref, plate, mb, nodes, out


def omega_error(r, ref, start=PULSE):
    """max over t >= start of |omega - omega_ref| / |omega_ref| (body frame)."""
    w_ref = cols(ref, "omega_", "123")
    sel = ref["t"] >= start - 1e-9
    return float(np.max(np.linalg.norm(r.omega[sel] - w_ref[sel], axis=1) / np.linalg.norm(w_ref[sel], axis=1)))


def deflection_error(u, u_ref):
    """max over t of |u - u_ref| relative to max over t of |u_ref|; and the peak ratio."""
    peak = np.max(np.linalg.norm(u_ref, axis=1))
    return (float(np.max(np.linalg.norm(u - u_ref, axis=1)) / peak),
            float(np.max(np.linalg.norm(u, axis=1)) / peak))


def test_same_model(runs):
    """The reference was made from the same model: frequencies, grid, load node."""
    meta, ref, plate, mb, nodes, out = runs
    f_ref = np.array([float(v) for v in meta["flexible frequencies (Hz)"].split()])
    np.testing.assert_allclose(f_ref, mb.frequencies_hz, rtol=1e-7)
    assert meta["model"].startswith("plate divisions 20x2x1 (1845 DOFs), 10 flexible modes, zeta 0.05")
    assert meta["source"].startswith("Exudyn ")
    # "0.0010" parses to fl(k/1000); k * fl(1e-3) has 2 roundings: 3 in all, relative to t
    grid = np.arange(1001) * 1e-3
    assert np.all(np.abs(ref["t"] - grid) <= gamma(3) * grid)
    np.testing.assert_allclose(out[True][0].t, ref["t"], atol=1e-9)
    # mesh coordinates are linspace values start + i (stop - start) / n: 4 roundings on terms <= |start| + |stop|
    extent = np.array([sum(map(abs, X_RANGE)), sum(map(abs, Y_RANGE)), sum(map(abs, Z_RANGE))])
    assert np.all(np.abs(plate.nodes[nodes["load"]] - LOAD_POINT) <= gamma(4) * extent)


def test_omega_after_load(runs):
    """Deformed load arm (as Exudyn): omega after the load within 0.1% (measured ~1e-7).  The linear
    lever arm misses the moment impulse of u_F x f: its error is that impulse through the inertia."""
    meta, ref, plate, mb, nodes, out = runs
    err = {arm: omega_error(out[arm][0], ref) for arm in (True, False)}
    i1 = int(round(PULSE / 1e-3))
    w_ref = cols(ref, "omega_", "123")
    print(f"\nExudyn omega after the load (t = {ref['t'][i1]:.3f} s): {w_ref[i1]} rad/s")
    for arm in (True, False):
        print(f"flexfmu consistent, deformed_load_arm={arm!s:5}: omega(0.01 s) = {out[arm][0].omega[i1]}, "
              f"max_t>=0.01 |omega - omega_Exudyn| / |omega_Exudyn| = {err[arm]:.3g}")
    assert err[True] <= 1e-3                     # the bound asked for
    assert err[True] <= 1e-6                     # what is measured (~1e-7): the u_F x f effect (~7e-6) is resolved
    # Linear arm: missing moment impulse dL = int (u_F x f) dt (body frame; u_F from flexfmu's deformed-arm run
    # on a fine grid, f the pulse), so omega_linear - omega_deformed = -J^-1 dL after the load.
    integ = ReframeIntegrator(plate, mb, deformed_load_arm=True)
    fine = integ.run(PULSE, DT / 10, PointLoad(LOAD_POINT, half_sine_pulse(FORCE, PULSE)))
    u_fine = fine.q @ mb.flexible[3 * nodes["load"]:3 * nodes["load"] + 3].T
    f_body = np.array([R.T @ (FORCE * math.sin(math.pi * t / PULSE)) for R, t in zip(fine.rotation, fine.t)])
    dL = np.trapezoid(np.cross(u_fine, f_body), fine.t, axis=0)
    dw_pred = -np.linalg.solve(mb.inertia, dL)
    dw = out[False][0].omega[i1] - out[True][0].omega[i1]
    print(f"linear - deformed arm at 0.01 s: {dw} rad/s; -J^-1 int(u_F x f) dt = {dw_pred} rad/s")
    np.testing.assert_allclose(dw, dw_pred, rtol=0.05, atol=0.05 * np.linalg.norm(dw_pred))
    assert err[False] > 10 * err[True]           # the deformed arm is what makes the agreement


@pytest.mark.parametrize("point", ["load", "far"])
def test_tip_deflection(runs, point):
    """Elastic displacement (body frame) of the loaded tip and of the opposite tip: within 2% of Exudyn's
    over the whole second (relative to its peak).  The lever arm does not change the deflection (at this
    load the moment u_F x f changes omega by 7e-6 only)."""
    meta, ref, plate, mb, nodes, out = runs
    u_ref = cols(ref, f"u_{point}_")
    for arm in (True, False):
        e, peak = deflection_error(out[arm][1][point], u_ref)
        print(f"\n{point} tip, deformed_load_arm={arm!s:5}: max |u - u_Exudyn| / max |u_Exudyn| = {e:.3g}, "
              f"peak ratio {peak:.6f} (Exudyn peak {np.max(np.linalg.norm(u_ref, axis=1)):.6e} m)")
        assert e <= 0.02
        assert abs(peak - 1.0) <= 0.02


def test_com_velocity(runs):
    """Both codes conserve linear momentum: v_com = impulse / m after the pulse (impulse 2 T F / pi)."""
    meta, ref, plate, mb, nodes, out = runs
    v_ref = cols(ref, "com_vel_")
    expected = 2.0 * PULSE / math.pi * FORCE / mb.mass
    r = out[True][0]
    sel = ref["t"] >= PULSE
    err_ref = np.max(np.linalg.norm(v_ref[sel] - expected, axis=1)) / np.linalg.norm(expected)
    err = np.max(np.linalg.norm(r.com_velocity[sel] - v_ref[sel], axis=1)) / np.linalg.norm(expected)
    print(f"\nCOM velocity: Exudyn vs impulse/m {err_ref:.2g}, flexfmu vs Exudyn {err:.2g}")
    assert err_ref <= 1e-6 and err <= 1e-6
