"""The flexible barge: the wave converter's platform as a free flexible body carrying the harvester.

Builds the barge (flexfmu.wec.barge: a ballasted HDPE-like slab with the box's length and beam, the point-mass
part of the BEM infinite-frequency added mass at O, the modes up to 1.5x the harvester's first frequency plus the
interfaces' static correction), exports it as an FMU and writes the system: the wave-converter example with
Platform replaced by the barge (examples/flexible_barge/OspSystemStructure.xml).  docs/wave_converter.md,
"Flexible barge".

    python examples/flexible_barge/make_barge.py --out dist          # writes dist/Barge.fmu and the system file
    flexfmu cosim examples/flexible_barge/OspSystemStructure.xml --t-end 10
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(ROOT / "dist"), help="folder for Barge.fmu (default: dist)")
    parser.add_argument("--E", type=float, default=1.0e9, help="hull Young's modulus, Pa (default 1e9: HDPE)")
    parser.add_argument("--f-max", type=float, default=None,
                        help="highest frequency kept, Hz (default: 1.5x the harvester's first clamped frequency)")
    parser.add_argument("--system", default=str(HERE / "OspSystemStructure.xml"), help="system file to write")
    parser.add_argument("--gauge", action="append", default=None, metavar="NAME=SET|X,Y,Z",
                        help="a stress gauge of the hull, as flexfmu export --gauge (repeatable; default: 'deck', "
                             "midship a quarter beam off the centreline just under the deck)")
    args = parser.parse_args(argv)

    from flexfmu.cosim.masters import load_system, write_osp
    from flexfmu.fmi.export import export_fmu
    from flexfmu.wec.barge import BargeParameters, barge_system, build_barge, deck_gauge, harvester_f1
    from flexfmu.wec.components import bem_added_mass_inf, bem_database

    wec = load_system(ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml")
    f_max = args.f_max if args.f_max is not None else 1.5 * harvester_f1(wec)
    params = BargeParameters(E=args.E)
    A_inf = bem_added_mass_inf(bem_database(params.box))
    with tempfile.TemporaryDirectory() as tmp:
        gauges = args.gauge if args.gauge is not None else [deck_gauge(params)]
        body = build_barge(params, tmp, A_inf=A_inf, f_max=f_max, tolerance=1e-2, gauges=gauges)
    for line in body.messages:
        print(line)
    fmu = export_fmu(body, Path(args.out) / "Barge.fmu")
    print(f"wrote {fmu}: {body.summary()}")
    system = barge_system(wec, fmu)
    print(f"wrote {write_osp(system, args.system, relative=True)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
