#!/usr/bin/env python3
"""Plot the wave-converter system with the exported bracket (docs/export.md): the platform's heave, the
bracket tip's elastic displacement (body frame), the force the bracket puts on the platform, and the
power the PTO takes from the bracket tip.

    python examples/bracket/plot_system.py RESULT.csv PNG
"""
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(csv_path: str, png_path: str) -> None:
    data = np.genfromtxt(csv_path, delimiter=",", names=True, deletechars="")
    t = data["time"]
    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    axes[0].plot(t, data["platform.pos_z"] * 1e3)
    axes[0].set_ylabel("platform heave (mm)")
    rest = np.array([data["bracket.tip.pos_" + a][0] for a in "xyz"])
    for a, r in zip("xyz", rest):
        axes[1].plot(t, (data["bracket.tip.pos_" + a] - r) * 1e6, label=f"tip {a}")
    axes[1].set_ylabel("tip elastic displ. (um, body)")
    axes[1].legend(loc="upper right", fontsize=8)
    for a in "xyz":
        axes[2].plot(t, data["bracket.reaction_F_" + a], label=f"F_{a}")
    axes[2].set_ylabel("bracket on platform (N, body)")
    axes[2].legend(loc="upper right", fontsize=8)
    axes[3].plot(t, data["pto.power"] * 1e6)
    axes[3].set_ylabel("PTO power (uW)")
    axes[3].set_xlabel("time (s)")
    fig.suptitle("wave converter with the exported bracket (Bracket.fmu) in place of the harvester")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    print(f"wrote {png_path}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
