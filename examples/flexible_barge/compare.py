"""The flexible barge against its rigid counterpart in the wave-converter system, through FMUs (fmpy master).

Runs examples/flexible_barge/OspSystemStructure.xml (made by make_barge.py) and the wave-converter example with
its Platform given the barge's rigid-body mass matrix and mount point (flexfmu.wec.barge.rigid_system), both with
the BEM hydrodynamics, and plots platform heave and pitch, the harvester's relative motion, the acceleration at the mount
and what the barge's flexibility adds to it (barge minus rigid).

    python examples/flexible_barge/compare.py --t-end 10 --fmu-dir dist --plot dist/barge_vs_rigid.png
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--t-end", type=float, default=10.0, help="simulated time, s (default 10)")
    parser.add_argument("--fmu-dir", default=str(ROOT / "dist"), help="folder with the FMUs and Barge.fmu")
    parser.add_argument("--plot", default=str(ROOT / "dist" / "barge_vs_rigid.png"), help="PNG to write")
    args = parser.parse_args(argv)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexfmu.cosim.masters import load_system, run
    from flexfmu.wec.barge import BargeParameters, harvester_f1, rigid_system

    fmu_dir = Path(args.fmu_dir)
    barge = load_system(HERE / "OspSystemStructure.xml").with_fmu_dir(fmu_dir)
    rigid = rigid_system(load_system(ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"),
                         BargeParameters()).with_fmu_dir(fmu_dir)
    runs = {name: run(system, args.t_end, progress=True) for name, system in (("rigid", rigid), ("barge", barge))}
    keys = {"rigid": {"heave": "platform.pos_z", "pitch": "platform.rot_y", "mount": "platform.mount_a_x"},
            "barge": {"heave": "barge.hydro.pos_z", "pitch": "barge.rot_y", "mount": "barge.mount.acc_x"}}
    fig, ax = plt.subplots(2, 2, figsize=(11, 7))
    half = None
    for name, result in runs.items():
        t, c = result.t, result.columns
        half = t >= t[-1] / 2
        ax[0, 0].plot(t, c[keys[name]["heave"]] * 1e3, label=f"{name}: heave")
        ax[0, 0].plot(t, np.degrees(c[keys[name]["pitch"]]) * 10, "--", label=f"{name}: pitch x 10")
        ax[0, 1].plot(t, c["harvester.sensor_u_z"] * 1e6, label=name)
        ax[1, 0].plot(t, c[keys[name]["mount"]], label=name, lw=0.8)
        power = np.mean(c["pto.power"][half])
        print(f"{name}: heave amplitude {0.5 * np.ptp(c[keys[name]['heave']][half]) * 1e3:.3f} mm, harvester "
              f"sensor_u_z amplitude {0.5 * np.ptp(c['harvester.sensor_u_z'][half]) * 1e6:.3f} um, mean power "
              f"{power:.4g} W (second half)")
    ax[0, 0].set(xlabel="t (s)", ylabel="heave (mm), pitch (deg x 10)", title="platform motion at O")
    ax[0, 1].set(xlabel="t (s)", ylabel="sensor_u_z (um)", title="harvester point, elastic, relative to its base")
    ax[1, 0].set(xlabel="t (s)", ylabel="m/s2", title="surge acceleration at the mount")
    rb, rr = runs["barge"], runs["rigid"]
    for axis, what in zip("xz", ("surge", "heave")):
        diff = rb.columns[f"barge.mount.acc_{axis}"] - rr.columns[f"platform.mount_a_{axis}"]
        ax[1, 1].plot(rb.t, diff * 1e3, lw=0.8, label=f"{what}")
    for column in sorted(c for c in rb.columns if c.startswith("barge.") and c.endswith(".von_mises")):
        # the hull's stress gauges (make_barge.py --gauge): their largest von Mises stress over the run
        k = int(np.argmax(rb.columns[column]))
        print(f"barge: {column} largest {rb.columns[column][k] / 1e3:.4g} kPa at t = {rb.t[k]:.4g} s")
    f_barge, f_harvester = float(rb.columns["barge.f_1"][-1]), harvester_f1(rigid)
    ax[1, 1].set(xlabel="t (s)", ylabel="mm/s2", title="mount acceleration: barge - rigid")
    ax[1, 1].text(0.02, 0.04, f"barge f_1 {f_barge:.1f} Hz, harvester f_1 {f_harvester:.1f} Hz",
                  transform=ax[1, 1].transAxes, fontsize=8, color="grey")
    for a in ax.flat:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.suptitle("Wave converter: flexible barge (HDPE slab, free body) vs its rigid counterpart; BEM, 1.4 s waves")
    fig.tight_layout()
    Path(args.plot).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.plot, dpi=110)
    print(f"wrote {args.plot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
