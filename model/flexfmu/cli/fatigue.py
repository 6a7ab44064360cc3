"""`flexfmu fatigue`: rainflow counting and Miner damage of one column of a result CSV, or of the critical point of a
signed stress scan (a beam section's fibres, a solid gauge's planes) (flexfmu.fatigue)."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from flexfmu.errors import ParameterError


def _cut_off(text: str | None, curve):
    """The curve with the --cut-off the user gave: a range in the curve's unit, or "limit" (its fatigue limit)."""
    if text is None:
        return curve
    if text.strip().lower() == "limit":
        if curve.fatigue_limit is None:
            raise ParameterError("cut-off", f"limit: {curve.name} has no fatigue limit in its table",
                                 "a range in the curve's unit, or limit with a DNV-<class>, DNV-<class>-CP or BS "
                                 "curve; --sn takes its cut-off as its third number")
        return curve.with_cutoff(curve.fatigue_limit)
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        raise ParameterError("cut-off", f"{text!r}", f"a range > 0 in {curve.unit}, or limit")
    return curve.with_cutoff(value)


def _fatigue(args: argparse.Namespace) -> int:
    """flexfmu fatigue: the column's history, the curve, the assessment; the table printed, CSV and chart written."""
    from flexfmu.cosim.checks import check_output_path
    from flexfmu.fatigue import assess_history, curve_from_text, history_from_csv, named_curve
    from flexfmu.fatigue.chart import plot_range_histogram
    from flexfmu.fatigue.sn_curve import unit_scale

    unit_scale(args.unit, "unit")
    if args.sn is not None:
        if args.cut_off is not None:
            raise ParameterError("cut-off", "with --sn", "the cut-off as --sn's third number: m,log10a,cutoff")
        curve = curve_from_text(args.sn, unit=args.sn_unit, parameter="sn")
    else:
        curve = _cut_off(args.cut_off, named_curve(args.curve, "curve"))
    if not (math.isfinite(args.scf) and args.scf > 0.0):
        raise ParameterError("scf", f"{args.scf!r}", "a finite stress concentration factor > 0")
    if not (math.isfinite(args.n_ref) and args.n_ref > 0.0):
        raise ParameterError("n-ref", f"{args.n_ref!r}", "a finite reference cycle count > 0")
    if not 1 <= args.bins <= 1000:
        raise ParameterError("bins", f"{args.bins}", "an integer 1 .. 1000")
    check_output_path(args.out, "out")
    check_output_path(args.plot, "plot")
    check_output_path(args.scan_out, "scan-out")
    if args.section is not None and args.section_gauge is None:
        raise ParameterError("section", f"{args.section!r} without --section-gauge",
                             "--section only with --section-gauge PREFIX")
    if args.scan_out is not None and args.gauge is not None:
        raise ParameterError("scan-out", "with --gauge (one column, nothing scanned)",
                             "--scan-out with --section-gauge or --tensor-gauge")
    if args.gauge is not None:
        history = history_from_csv(args.result, args.gauge, time_column=args.time_column, unit=args.unit,
                                   t_start=args.t_start, parameter="gauge")
        if args.scf != 1.0:
            history = type(history)(history.time, history.stress * args.scf, f"{history.name} x SCF {args.scf:g}",
                                    history.unit)
        assessment = assess_history(history, curve, n_ref=args.n_ref, n_bins=args.bins)
        scan = None
        print(f"{args.result}: {args.gauge}, t = {history.time[0]:g} .. {history.time[-1]:g} s "
              f"({history.time.size} samples, stress in {args.unit})")
    else:
        scan, time, what = _signed_scan(args, curve)
        assessment = scan.assessment
        print(f"{args.result}: {what}, t = {time[0]:g} .. {time[-1]:g} s ({time.size} samples)")
        print("\n".join(scan.summary_lines()))
    print(assessment.table())
    if curve.source:
        print(f"curve: {curve.source}")
    if args.out is not None:
        print(f"wrote {assessment.write_csv(args.out)}")
    if args.plot is not None:
        print(f"wrote {plot_range_histogram(assessment, args.plot)}")
    if args.scan_out is not None:
        print(f"wrote {scan.write_places_csv(args.scan_out)}")
    return 0


def _signed_scan(args: argparse.Namespace, curve):
    """The signed stress scan of --section-gauge (fibres round --section) or --tensor-gauge (planes), the times it
    covers (s) and the text saying which columns it read."""
    from flexfmu.fatigue.gauge_columns import read_time_and_columns, section_columns, tensor_columns
    from flexfmu.fatigue.section_points import BeamSection
    from flexfmu.fatigue.signed_scan import critical_plane_scan, section_scan

    if args.section_gauge is not None:
        if args.section is None:
            raise ParameterError("section", "missing: --section-gauge needs the section",
                                 "--section circle:D, tube:DO,DI or rectangle:B,H (m; B along z, H along y), or "
                                 "scene:NAME|PATH (the FFRBeam instance's scene)")
        if args.unit != "Pa":
            raise ParameterError("unit", f"{args.unit} with --section-gauge",
                                 "Pa: the stress comes from N (N), My, Mz (N m) and --section (m)")
        section = _section(args.section, BeamSection)
        columns, torsion = section_columns(args.result, args.section_gauge, "section-gauge")
        t, v = read_time_and_columns(args.result, columns + ([torsion] if torsion else []),
                                     time_column=args.time_column, t_start=args.t_start, parameter="section-gauge")
        scan = section_scan(t, v[:, 0], v[:, 1], v[:, 2], section, curve, name=args.section_gauge, scf=args.scf,
                            n_ref=args.n_ref, n_bins=args.bins, torsion=v[:, 3] if torsion else None)
        return scan, t, ", ".join(columns) + f" (N, N m) at the {section.describe()}"
    columns = tensor_columns(args.result, args.tensor_gauge, "tensor-gauge")
    t, v = read_time_and_columns(args.result, columns, time_column=args.time_column, t_start=args.t_start,
                                 parameter="tensor-gauge")
    scan = critical_plane_scan(t, v, curve, name=args.tensor_gauge, unit=args.unit, scf=args.scf, n_ref=args.n_ref,
                               n_bins=args.bins)
    return scan, t, f"{columns[0]} .. {columns[-1]} (stress in {args.unit}, body frame)"


def _section(text: str, beam_section):
    """--section: circle:D, tube:DO,DI, rectangle:B,H, or scene:NAME|PATH, the one section of an FFRBeam scene (a
    built-in name or a scene JSON: what the instance's ``scene`` parameter names)."""
    shape, _, rest = text.strip().partition(":")
    if shape.strip().lower() != "scene":
        return beam_section.from_text(text, "section")
    from flexfmu.ffr.scene import load_scene

    section = load_scene(rest.strip(), parameter="section").section
    return beam_section.from_constants(section.shape, section.A, section.Iy, section.Iz, "section")


def add_parser(sub) -> None:
    """Add `flexfmu fatigue` to ``sub``, the sub-commands of build_parser."""
    p = sub.add_parser(
        "fatigue", help="rainflow counting and Miner damage of a stress column of a result CSV",
        description="Fatigue of one stress history: the column --gauge of a result CSV (flexfmu cosim --out; time "
                    "in the first column or one named time), rainflow-counted (ASTM E1049-85, the rainflow package: "
                    "pip install 'flexfmu[fatigue]'), each cycle's damage on an S-N curve (--sn or a named --curve) "
                    "summed by Miner's rule. Prints the ranges binned with their cycles and damage, the total "
                    "damage, the equivalent constant-amplitude range for --n-ref cycles, the damage rate per second "
                    "of the record and the life it implies in hours and years; writes the bins as CSV (--out) and "
                    "a range histogram (--plot). --section-gauge and --tensor-gauge make signed histories instead "
                    "of one column: the axial stress at points round a beam section, or the normal stress on every "
                    "plane through a solid gauge's point, and assess the critical one. No mean-stress correction, "
                    "no multiaxial criterion beyond the normal stress (docs/fatigue.md).")
    p.add_argument("result", metavar="RESULT.csv", type=Path, help="the result CSV")
    gauge = p.add_mutually_exclusive_group(required=True)
    gauge.add_argument("--gauge", default=None, metavar="COLUMN",
                       help="one stress column, e.g. harvester.gauge_1_sigma_max (unsigned: see docs/fatigue.md)")
    gauge.add_argument("--section-gauge", default=None, metavar="PREFIX",
                       help="a beam gauge's section forces PREFIX_N, PREFIX_My, PREFIX_Mz (e.g. harvester.gauge_1): "
                            "the signed axial stress at points round --section's outline, the critical one assessed")
    gauge.add_argument("--tensor-gauge", default=None, metavar="NAME",
                       help="a solid gauge's stress NAME.sigma_xx .. NAME.sigma_xz: the normal stress on planes of "
                            "every orientation (critical plane, ~800 planes), the critical one assessed")
    p.add_argument("--section", default=None, metavar="circle:D|tube:DO,DI|rectangle:B,H|scene:NAME",
                   help="with --section-gauge: the section at the gauge, m (B the width along the section's z, H the "
                        "height along y; docs/scene_format.md), or scene:NAME|PATH, the section of the FFRBeam "
                        "instance's scene (its 'scene' parameter: a built-in name or a scene JSON)")
    curve = p.add_mutually_exclusive_group(required=True)
    curve.add_argument("--sn", default=None, metavar="m,log10a[,cutoff]",
                       help="a one-slope curve N = a S^-m (S in --sn-unit), with ranges below cutoff doing no damage")
    curve.add_argument("--curve", default=None, metavar="NAME",
                       help="a named curve in MPa: DNV-<class> (DNV-RP-C203 2016 Table 2-1, in air: B1, B2, C, C1, "
                            "C2, D, E, F, F1, F3, G, W1, W2, W3), DNV-<class>-CP (Table 2-2, seawater with cathodic "
                            "protection), DNV-<class>-FC (Table 2-4, free corrosion), BS-<class> (BS 7608:1993 "
                            "Table 10, mean - 2 SD: B, C, D, E, F, F2, G, W); two slopes as the tables give them")
    p.add_argument("--cut-off", default=None, metavar="S|limit",
                   help="with --curve: ranges below S (the curve's unit) do no damage; limit: the curve's fatigue "
                        "limit at 1e7 cycles (constant-amplitude loading)")
    p.add_argument("--unit", default="Pa", choices=("Pa", "kPa", "MPa", "GPa"),
                   help="the column's stress unit (default Pa, flexfmu's outputs)")
    p.add_argument("--sn-unit", default="MPa", choices=("Pa", "kPa", "MPa", "GPa"),
                   help="the unit of --sn's S (default MPa)")
    p.add_argument("--scf", type=float, default=1.0, metavar="K",
                   help="stress concentration factor the column is multiplied by (default 1)")
    p.add_argument("--t-start", type=float, default=None, metavar="T",
                   help="leave out t < T s (a start-up transient)")
    p.add_argument("--time-column", default=None, metavar="NAME",
                   help="the time column (default: 'time' or 't' if present, else the first column)")
    p.add_argument("--n-ref", type=float, default=1e7, metavar="N",
                   help="reference cycle count of the equivalent range (default 1e7)")
    p.add_argument("--bins", type=int, default=20, metavar="N", help="range bins of the table (default 20)")
    p.add_argument("--out", type=Path, default=None, metavar="table.csv", help="write the bins as CSV")
    p.add_argument("--plot", type=Path, default=None, metavar="hist.png", help="write the range histogram (PNG)")
    p.add_argument("--scan-out", type=Path, default=None, metavar="places.csv",
                   help="with --section-gauge or --tensor-gauge: every scanned point or plane with its damage")
    p.set_defaults(func=_fatigue)
