#!/usr/bin/env python3
"""The floating box's RAO with ``hydrodynamics = "bem"``: co-simulation against the frequency domain
(docs/wave_converter.md, "The BEM model in the components"; the chart docs/figures/wave_bem_rao.png).

    python examples/wave_converter/rao_chart.py [--periods 1.0 1.2 ...] [--t-end 60] [--step 0.001]
                                                [--figures docs/figures | --no-chart]

Co-simulates the three library simulators (WaveExcitation, Platform, Hydrostatics; no harvester, no PTO)
with hydrodynamics = "bem" in regular head waves, H = 0.02 m, a 10 s ramp, Gauss-Seidel at the given step
(flexfmu.wec.rao.cosimulated_motion, as tests/test_wave_bem_cosim.py does), fits the steady complex
amplitude over the last whole periods within 8 s (flexfmu.wec.rao.steady_amplitude) and prints, per
period, co-sim / frequency-domain |RAO| (flexfmu.wec.bem.response_amplitude_operator for the box's rigid
mass matrix, eq. BEM.2) and their complex difference, as the doc's table.  The chart: |RAO| of surge, heave
and pitch over 0.8-3 s in the frequency domain for the BEM model and for the constant-coefficient model
(flexfmu.wec.rao.constant_rao: Froude-Krylov, strip-theory added mass, constant damping), the
co-simulated points marked.  Needs the bem extra (Capytaine); ~8 s wall per 60 s period at 1 ms.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
PERIODS = (1.0, 1.2, 1.4, 1.7, 2.0, 2.5)
DOFS = ((0, "surge", "m/m"), (2, "heave", "m/m"), (4, "pitch", "rad/m"))
T_RANGE = (0.8, 3.0)


def _fmt(v: float) -> str:
    return f"{v:.4f}" if abs(v) < 2 else f"{v:.3f}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--periods", type=float, nargs="+", default=PERIODS, help="wave periods (s)")
    parser.add_argument("--t-end", type=float, default=60.0, help="length of each run (s)")
    parser.add_argument("--step", type=float, default=1e-3, help="communication step (s)")
    parser.add_argument("--figures", default=str(ROOT / "docs" / "figures"), help="where wave_bem_rao.png goes")
    parser.add_argument("--no-chart", action="store_true", help="print the table only")
    args = parser.parse_args(argv)

    from flexfmu.wec import bem
    from flexfmu.wec.components import bem_database
    from flexfmu.wec.hydrostatics import HydrostaticsConfig, HydrostaticsSimulator
    from flexfmu.wec.rao import HEIGHT, constant_rao, cosimulated_motion, steady_amplitude
    from flexfmu.wec.wave import BoxParameters

    box = BoxParameters()
    ds = bem_database(box)
    M = box.box().rigid_mass_matrix()
    a = HEIGHT / 2
    order = HydrostaticsSimulator(HydrostaticsConfig(hydrodynamics="bem")).radiation.order
    print(f"radiation memory (Hydrostatics, six DOFs): order {order}")

    points = {}
    rows = []
    for period in args.periods:
        omega = 2 * math.pi / period
        _, rao = bem.response_amplitude_operator(ds, M, 0.0, [omega])
        start = time.perf_counter()
        t, xi, eta = cosimulated_motion(period, args.t_end, args.step)
        wall = time.perf_counter() - start
        assert abs(steady_amplitude(t, eta, omega) / a - 1) < 1e-9     # the phase reference: a cos(w t) at O
        cells = []
        for d, name, _ in DOFS:
            z = steady_amplitude(t, xi[:, d], omega) / a
            ref = rao[0, d]
            err = abs(z - ref) / abs(ref)
            points.setdefault(name, []).append((period, abs(z)))
            cells.append(f"{_fmt(abs(z))} / {_fmt(abs(ref))} ({100 * err:.2f} %)")
            print(f"T = {period:g} s {name}: co-sim {abs(z):.5f} (phase {math.degrees(np.angle(z)):8.3f} deg), "
                  f"FD {abs(ref):.5f} (phase {math.degrees(np.angle(ref)):8.3f} deg), amplitude "
                  f"{100 * (abs(z) / abs(ref) - 1):+.2f} %, complex difference {100 * err:.3f} %", flush=True)
        print(f"  ({wall:.1f} s wall for {args.t_end:g} s at {args.step * 1e3:g} ms)", flush=True)
        rows.append(f"| {period:.1f} | " + " | ".join(cells) + " |")
    print(f"\nRuns of {args.t_end:g} s at {args.step * 1e3:g} ms:\n")
    print("| T (s) | surge co-sim / FD (m/m) | heave co-sim / FD (m/m) | pitch co-sim / FD (rad/m) |")
    print("|---|---|---|---|")
    print("\n".join(rows))
    if args.no_chart:
        return 0

    # frequency domain over 0.8-3 s, fine enough in w for the pitch resonance (half-power width ~0.02 rad/s)
    w = np.linspace(2 * math.pi / T_RANGE[1], 2 * math.pi / T_RANGE[0], 6001)
    _, rao_bem = bem.response_amplitude_operator(ds, M, 0.0, w)
    rao_const = constant_rao(w)
    periods = 2 * math.pi / w
    for d, name, unit in DOFS:
        kb, kc = int(np.argmax(np.abs(rao_bem[:, d]))), int(np.argmax(np.abs(rao_const[:, d])))
        print(f"{name}: BEM peak {abs(rao_bem[kb, d]):.3f} {unit} at {periods[kb]:.3f} s; "
              f"constant peak {abs(rao_const[kc, d]):.3f} at {periods[kc]:.3f} s")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(14, 4.6))
    for ax, (d, name, unit) in zip(axes, DOFS):
        ax.plot(periods, np.abs(rao_bem[:, d]), "-", color="tab:blue", lw=1.6, label="BEM, frequency domain (BEM.2)")
        ax.plot(periods, np.abs(rao_const[:, d]), "--", color="0.45", lw=1.4,
                label="constant coefficients, frequency domain")
        pts = np.array(points[name])
        ax.plot(pts[:, 0], pts[:, 1], "o", color="tab:orange", ms=7, mec="k", mew=0.6, zorder=5,
                label=f"BEM, co-simulation ({args.step * 1e3:g} ms, Gauss-Seidel, {args.t_end:g} s)")
        ax.set_title(name, fontsize=12)
        ax.set_xlabel("wave period T (s)")
        ax.set_ylabel(f"|{name} RAO| ({unit})")
        ax.set_xlim(*T_RANGE)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        if name == "pitch":              # the potential-flow resonance peak (22 rad/m) would flatten the rest
            top = 1.15 * max(np.abs(rao_const[:, d]).max(), pts[:, 1].max())
            peak = np.abs(rao_bem[:, d]).max()
            ax.set_ylim(0, top)
            ax.annotate(f"peak {peak:.1f} rad/m at {periods[np.argmax(np.abs(rao_bem[:, d]))]:.2f} s",
                        xy=(periods[np.argmax(np.abs(rao_bem[:, d]))], top), xytext=(1.6, 0.85 * top),
                        fontsize=9, arrowprops=dict(arrowstyle="->", color="tab:blue", lw=0.8), color="tab:blue")
        if name == "surge":
            top = 1.15 * max(np.abs(rao_bem[:, d]).max(), np.abs(rao_const[:, d]).max())
            ax.set_ylim(0, top)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=10, frameon=False)
    fig.suptitle(f"Floating box {box.length:.1f} x {box.beam:.1f} x {box.draft:.2f} m, head seas: |RAO| per unit "
                 f"wave amplitude", fontsize=12)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    path = Path(args.figures) / "wave_bem_rao.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
