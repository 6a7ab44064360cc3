"""What the power matrix (flexfmu.wec.system.power_matrix) takes from the system file's instances: the study's
defaults for the system it runs, the discrete spectrum each wave component plays for a sea state, the device's
characteristic width, whether the configuration is linear, and then the frequency-domain prediction of the mean
power from the same BEM database.

Two systems are served.  The point absorber (examples/point_absorber/: AbsorberWave, AbsorberFloat, AbsorberHydro,
HeavePTO, Mooring; full scale) gets the standard's study: 20-minute sea states after the wave's ramp, the wave's
record as long as the run (so it does not repeat within it), three seeds per bin and the bin checks of
IEC TS 62600-100.  The wave converter with its harvester (examples/wave_converter/: a 1 m box in centimetre seas) keeps
its former study: 60 s runs, the mean over their second half, the harvester's boundary; the standard's full-scale
bin widths mean nothing there, so its bins are not checked unless asked for.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import require
from flexfmu.wec.iec import IEC_HS_BIN_WIDTH, IEC_TE_BIN_WIDTH, MIN_RUNS_PER_BIN, SeaSpectrum

#: the length of a sea state the standard's power matrix is made of (s): 20 minutes, after the wave's ramp
SEA_STATE_DURATION = 1200.0
#: the former study of the harvester's system: its runs' length (s)
HARVESTER_T_END = 60.0
#: the point absorber's grid when none is given: Hs (m) x Tp (s)
ABSORBER_HEIGHTS = (1.0, 2.0, 3.0)
ABSORBER_PERIODS = (6.0, 8.0, 10.0, 12.0)
HARVESTER_HEIGHTS = (0.05, 0.1, 0.15, 0.2)
HARVESTER_PERIODS = (1.0, 1.2, 1.4, 1.6, 2.0)
#: the models of the point absorber's components whose parameters make its configuration linear
LINEAR_SETTINGS = {"AbsorberFloat": ("heave_only", True), "AbsorberHydro": ("drag", False),
                   "Mooring": ("enabled", False)}


@dataclass(frozen=True)
class StudyDefaults:
    """The power matrix's defaults for one system: runs' length (s), start of the statistics window (s; None: half
    the run), whether the wave takes a record length, the grid, the harvester's boundary (None: no harvester) and
    whether the bins are checked against the standard."""

    t_end: float
    average_from: float | None
    record_length: bool
    heights: tuple
    periods: tuple
    boundary: str | None
    bin_checks: bool
    hs_bin_width: float = IEC_HS_BIN_WIDTH
    te_bin_width: float = IEC_TE_BIN_WIDTH
    min_runs: int = MIN_RUNS_PER_BIN


def _fields(config) -> set:
    return set(getattr(type(config), "__dataclass_fields__", {}))


def study_defaults(members) -> StudyDefaults:
    """The defaults for a roster (flexfmu.wec.roles.roster): with a harvester, the former study; otherwise the
    standard's, the runs SEA_STATE_DURATION after the wave's ramp and the statistics over those 20 minutes."""
    wave = members.one("wave").config
    ramp = max(float(getattr(wave, "ramp_time", 0.0)), 0.0)
    if members.of_kind("harvester"):
        return StudyDefaults(HARVESTER_T_END, None, "record_length" in _fields(wave), HARVESTER_HEIGHTS,
                             HARVESTER_PERIODS, "XFF", False)
    return StudyDefaults(ramp + SEA_STATE_DURATION, ramp, "record_length" in _fields(wave), ABSORBER_HEIGHTS,
                         ABSORBER_PERIODS, None, True)


# ---------------------------------------------------------------- the sea state each wave component plays
def jonswap_shape(omega, tp: float, gamma: float) -> np.ndarray:
    """The JONSWAP spectrum's shape at angular frequencies omega (rad/s) for peak period tp (s), by MHKiT
    (mhkit.wave.resource.jonswap_spectrum, IEC TS 62600-2 Annex C.2, in hertz); its scale is left to the caller,
    who normalises it over the components' band."""
    from flexfmu.wec.iec import mhkit_wave
    resource, _ = mhkit_wave()
    f = np.asarray(omega, float) / (2 * math.pi)
    s = resource.jonswap_spectrum(f.copy(), float(tp), 1.0, float(gamma), to_pandas=False)
    return np.asarray(next(iter(s.data_vars.values())).values, float)


def absorber_jonswap(hs: float, tp: float, gamma: float, record_length: float, n_components: int = 0,
                     rho: float = 1025.0, g: float = 9.81) -> SeaSpectrum:
    """The components of AbsorberWave's JONSWAP sea (the lead's specification): n bins of width dw = 2.5 w_p / n
    over 0.5 .. 3 w_p, each component at its bin's centre; n = ceil(2.5 w_p record_length / 2 pi) when 0, so that
    dw <= 2 pi / record_length; S_k = (Hs / 4)^2 s_k / (dw sum s_j), the band's Hm0 exactly Hs."""
    require(math.isfinite(hs) and hs > 0, "wave_height", f"got {hs!r}", "> 0 m")
    require(math.isfinite(tp) and tp > 0, "wave_period", f"got {tp!r}", "> 0 s")
    require(math.isfinite(record_length) and record_length > 0, "record_length", f"got {record_length!r}", "> 0 s")
    wp = 2 * math.pi / tp
    # ceil(2.5 w_p L / 2 pi) = ceil(2.5 L / Tp), as AbsorberWave counts: through w_p a whole 2.5 L / Tp would round
    # up by one
    n = int(n_components) if n_components else math.ceil(2.5 * record_length / tp - 1e-9)
    require(1 <= n <= 5000, "n_components", f"{n} components (record_length {record_length:g} s, Tp {tp:g} s)",
            "1 .. 5000")
    dw = 2.5 * wp / n
    w = 0.5 * wp + (np.arange(n) + 0.5) * dw
    s = jonswap_shape(w, tp, gamma)
    return SeaSpectrum(w, (hs / 4) ** 2 * s / (dw * s.sum()), dw, rho, g)


def excitation_jonswap(config, hs: float, tp: float) -> SeaSpectrum:
    """The components of WaveExcitation's JONSWAP sea (flexfmu.wec.wave.jonswap_sea): S_k = a_k^2 / (2 dw)."""
    from flexfmu.wec.wave import jonswap_sea
    sea = jonswap_sea(hs, tp, config.gamma, config.n_components, 1, 0.0, config.depth, config.g)
    dw = float(sea.omega[1] - sea.omega[0])
    return SeaSpectrum(sea.omega, sea.amplitude**2 / (2 * dw), dw, config.rho, config.g, max(config.depth, 0.0))


def sea_spectrum(wave_member, hs: float, tp: float, record_length: float | None) -> SeaSpectrum:
    """The discrete spectrum the system's wave component plays for a JONSWAP sea of Hs (m) and Tp (s) (its other
    parameters from the system file; the record length the run sets, when the component takes one)."""
    config = wave_member.config
    if wave_member.model == "WaveExcitation":
        return excitation_jonswap(config, hs, tp)
    require("record_length" in _fields(config), "SYSTEM_FILE", f"{wave_member.name}: {wave_member.model} has no "
            "JONSWAP spectrum known to the power matrix", "a WaveExcitation or AbsorberWave wave")
    length = float(config.record_length if record_length is None else record_length)
    return absorber_jonswap(hs, tp, config.gamma, length, int(config.n_components))


# ---------------------------------------------------------------- the device
def characteristic_width(members) -> float:
    """The device's characteristic width (m) that the capture-width ratio divides by: the point absorber's float
    diameter (twice its hull's radius), the harvester's box's beam."""
    body = members.one("platform")
    config = body.config
    if "beam" in _fields(config):
        return float(config.beam)
    if "radius" in _fields(config):
        return 2.0 * float(config.radius)
    require(body.model == "AbsorberFloat", "SYSTEM_FILE", f"{body.name}: {body.model} has no width known to the "
            "power matrix", "an AbsorberFloat or a box platform")
    from flexfmu.wec.absorber.hull import RADIUS
    return 2.0 * RADIUS


def _member_value(members, model: str, name: str):
    found = [m for m in members.members if m.model == model]
    return [getattr(m.config, name) for m in found]


def linear_configuration(members) -> bool:
    """Is the point absorber in its linear configuration: the float restrained to heave, the hydrodynamics without
    drag, the mooring disabled (or absent) and the PTO without a force limit?  What the frequency-domain prediction
    assumes."""
    if not [m for m in members.members if m.model == "HeavePTO"]:
        return False
    for model, (name, value) in LINEAR_SETTINGS.items():
        got = _member_value(members, model, name)
        if model == "Mooring" and not got:
            continue
        if len(got) != 1 or bool(got[0]) != value:
            return False
    limits = _member_value(members, "HeavePTO", "force_limit")
    return len(limits) == 1 and float(limits[0]) == 0.0


def spectral_prediction(members, spectrum: SeaSpectrum):
    """The frequency-domain mean power (W) of the linear configuration in this sea, from the same BEM database
    (flexfmu.wec.absorber.frequency_domain): P = sum_k S_k dw c w_k^2 |X_3(w_k) / Z(w_k)|^2; None when the
    configuration is not linear."""
    if not linear_configuration(members):
        return None
    from flexfmu.wec.absorber.frequency_domain import spectral_mean_power
    from flexfmu.wec.absorber.hull import absorber_hull
    pto = [m for m in members.members if m.model == "HeavePTO"][0].config
    return float(spectral_mean_power(absorber_hull(), spectrum.omega, spectrum.density, spectrum.d_omega,
                                     float(pto.damping), float(pto.stiffness)))


# ---------------------------------------------------------------- the bins' table
@dataclass
class CellTable:
    """The power matrix's cells: mean power (W) and the half width of its confidence interval (W) per Hs x Tp,
    the energy period of each Tp's column (s), one dict per computed bin (flexfmu.wec.iec.bin_statistics and the
    sea state's measures), the characteristic width (m) and the configuration's name."""

    power: np.ndarray
    ci_half_width: np.ndarray
    energy_periods: np.ndarray
    bins: list
    characteristic_width: float
    configuration: str


def cell_statistics(system, members, heights, periods, cells, rows, n_seeds, spectra, measures,
                    hs_bin_width, te_bin_width, min_runs, confidence) -> CellTable:
    """The statistics of each computed cell from its runs' rows (n_seeds consecutive rows per cell, in the order
    of ``cells``); each row gets its sea state's Hm0, Te, J and its capture width.  hs_bin_width / te_bin_width:
    the bins' widths when checked (their edges are written), else None."""
    from flexfmu.wec.iec import bin_edges, bin_statistics
    width = characteristic_width(members)
    linear = linear_configuration(members)
    power = np.full((len(heights), len(periods)), np.nan)
    half = np.full_like(power, np.nan)
    te_columns = np.full(len(periods), np.nan)
    bins = []
    for k, (i, j) in enumerate(cells):
        m = measures[(i, j)]
        te_columns[j] = m.te
        runs = rows[k * n_seeds:(k + 1) * n_seeds]
        for r in runs:
            r.update({"Hm0_m": m.hm0, "Te_s": m.te, "J_W_per_m": m.energy_flux,
                      "capture_width_m": r["mean_power_W"] / m.energy_flux})
        stats = bin_statistics([r["mean_power_W"] for r in runs], m.energy_flux, width, confidence)
        row = {"Hs_m": float(heights[i]), "Tp_s": float(periods[j]), "Hm0_m": m.hm0, "Te_s": m.te,
               "Te_over_Tp": m.te / float(periods[j]), "J_W_per_m": m.energy_flux}
        if hs_bin_width is not None:
            row["Hm0_bin_m"] = "%.6g .. %.6g" % bin_edges(float(heights[i]), hs_bin_width)
            row["Te_bin_s"] = "%.6g .. %.6g" % bin_edges(m.te, te_bin_width)
        row["runs"] = len(runs)
        row.update(stats)
        row["confidence"] = confidence
        row["meets_min_runs"] = stats["count"] >= min_runs
        if linear:
            predicted = spectral_prediction(members, spectra[(i, j)])
            row["spectral_power_W"] = predicted
            row["mean_over_spectral"] = stats["mean_power_W"] / predicted if predicted > 0 else float("nan")
            row["spectral_within_ci"] = bool(stats["ci_low_W"] <= predicted <= stats["ci_high_W"])
        bins.append(row)
        power[i, j] = stats["mean_power_W"]
        half[i, j] = stats["ci_half_width_W"]
    name = "linear (heave only, no drag, no mooring)" if linear else "as in the system file"
    return CellTable(power, half, te_columns, bins, width, name)
