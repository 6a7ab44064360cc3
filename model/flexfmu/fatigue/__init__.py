"""Fatigue assessment of stress histories (the gauge outputs of a result CSV): rainflow counting, S-N curves,
Miner damage, equivalent ranges, damage rates, and the damage over a sea-state or power-matrix scatter.

    sn_curve.py         SNCurve: N = a S^-m, a second slope below the knee, a cut-off; "m,log10a[,cutoff]" text
    standard_curves.py  the named curves of DNV-RP-C203 (2016, Tables 2-1, 2-2, 2-4) and BS 7608:1993 (Table 10)
    counting.py         rainflow cycles (ASTM E1049-85, the rainflow package; the optional extra 'fatigue')
    damage.py           Miner's sum, equivalent ranges, the damage binned by range
    history.py          StressHistory, and one from a result CSV's column
    assessment.py       one history on one curve: FatigueAssessment (table, CSV, damage rate, life)
    sea_states.py       bins with their share of the time: the long-term damage rate, life, lifetime damage
    chart.py            the range histogram (PNG)
    section_points.py   BeamSection: circle/tube/rectangle from text, its outline's points, sigma_xx there
    plane_normals.py    plane normals covering the hemisphere (a stated covering angle), normal stress n^T sigma n
    gauge_columns.py    a beam gauge's or a solid gauge's columns of a result CSV, found by its name, and read
    signed_scan.py      signed histories scanned: the fibres of a section, the planes of a point (critical plane)

Ranges are in the curve's unit (MPa for the named curves); histories carry their own (Pa for flexfmu's outputs).
docs/fatigue.md walks through it; ``flexfmu fatigue`` is the command.
"""
from __future__ import annotations

from .assessment import DEFAULT_N_REF, FatigueAssessment, assess_history
from .counting import Cycles, rainflow_cycles
from .damage import cycle_damage, damage_equivalent_range, equivalent_range, miner_damage
from .history import StressHistory, history_from_csv
from .sea_states import BinDamage, DamageBin, SeaStateDamage, sea_state_damage
from .section_points import BeamSection
from .signed_scan import PointScan, critical_plane_scan, section_scan
from .sn_curve import SNCurve, curve_from_text
from .standard_curves import curve_names, named_curve

__all__ = ["DEFAULT_N_REF", "BeamSection", "BinDamage", "Cycles", "DamageBin", "FatigueAssessment", "PointScan",
           "SNCurve", "SeaStateDamage", "StressHistory", "assess_history", "critical_plane_scan", "curve_from_text",
           "curve_names", "cycle_damage", "damage_equivalent_range", "equivalent_range", "history_from_csv",
           "miner_damage", "named_curve", "rainflow_cycles", "sea_state_damage", "section_scan"]
