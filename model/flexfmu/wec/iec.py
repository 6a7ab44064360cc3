"""The power matrix's statistics in the manner of IEC TS 62600-100 Ed. 2 (wave-energy converters, power
performance assessment): per bin of significant wave height Hm0 and energy period Te, the count, mean, standard
deviation, minimum and maximum of the runs' mean powers, the wave energy flux J of the bin's sea state, the capture
width P / J and its ratio to the device's characteristic width; the checks of the bins (width, overlap, minimum
count); and the spread over the seeds as a confidence interval of the mean.

The wave-resource and performance formulas are MHKiT's (``mhkit.wave.resource``: Hm0 = 4 sqrt(m0), Te = m_-1 / m0,
the deep-water J = rho g^2 / (64 pi) Hm0^2 Te; ``mhkit.wave.performance``: the capture width P / J and the bin
statistics, whose standard deviation has N degrees of freedom as the standard's formula D.5 says).  MHKiT is the
``iec`` extra; it is imported when a statistic is asked for, not with this module.

What is ours: the sea state's discrete spectrum (the spectrum the wave component actually plays, not the infinite
JONSWAP), handed to MHKiT in hertz; the bins centred on the simulated sea states; the confidence interval of the
mean over seeds, Student's t with n - 1 degrees of freedom on the sample standard deviation (n - 1 in its
denominator: the interval estimates the mean of the process, not the spread of these n runs); and the checks, which
refuse a grid (ParameterError naming the option) instead of warning as MHKiT's matrices do.

Units: SI; spectral density S(w) in m^2 s / rad over angular frequency w (rad/s), one-sided.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import ParameterError, require

#: IEC TS 62600-100: the widest bins of the power matrix, significant wave height (m) and energy period (s)
IEC_HS_BIN_WIDTH = 0.5
IEC_TE_BIN_WIDTH = 1.0
#: the fewest runs (seeds) a bin of the matrix is made of by default: the spread over seeds needs more than one,
#: and three is the least that gives its confidence interval a finite width worth quoting (t_{0.975, 2} = 4.30)
MIN_RUNS_PER_BIN = 3
#: the confidence level of the interval of a bin's mean power
CONFIDENCE = 0.95


def mhkit_wave():
    """(mhkit.wave.resource, mhkit.wave.performance), or a ParameterError saying how to install them."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)
            from mhkit.wave import performance, resource
    except ImportError as exc:
        raise ParameterError("power matrix", f"MHKiT is not installed ({exc})",
                             "install the 'iec' extra: pip install flexfmu[iec]") from None
    return resource, performance


# ---------------------------------------------------------------- the sea state
@dataclass(frozen=True)
class SeaSpectrum:
    """A discrete one-sided wave spectrum: components at angular frequencies ``omega`` (rad/s, increasing, equally
    spaced), each standing for a bin of width ``d_omega`` (rad/s) with density ``density`` S(w) (m^2 s/rad), so its
    amplitude is sqrt(2 S dw); sea water of density rho (kg/m^3) under gravity g (m/s^2), ``depth`` m deep
    (<= 0: deep water)."""

    omega: np.ndarray
    density: np.ndarray
    d_omega: float
    rho: float = 1025.0
    g: float = 9.81
    depth: float = 0.0

    def __post_init__(self):
        w, s = np.asarray(self.omega, float), np.asarray(self.density, float)
        require(w.ndim == 1 and w.size >= 2 and s.shape == w.shape, "spectrum",
                f"{w.size} frequencies and {s.size} densities", "two or more components, one density each")
        require(bool(np.all(np.isfinite(w)) and np.all(w > 0) and np.all(np.isfinite(s)) and np.all(s >= 0)
                     and s.sum() > 0), "spectrum", "frequencies not finite and > 0, or densities not finite, >= 0 "
                "and not all 0", "finite frequencies > 0 rad/s, densities >= 0")
        require(math.isfinite(self.d_omega) and self.d_omega > 0 and
                bool(np.allclose(np.diff(w), self.d_omega, rtol=1e-9, atol=0)), "spectrum",
                f"components not equally spaced by d_omega = {self.d_omega!r} rad/s", "equally spaced components")
        object.__setattr__(self, "omega", w)
        object.__setattr__(self, "density", s)

    @property
    def amplitudes(self) -> np.ndarray:
        """Each component's amplitude (m): sqrt(2 S dw)."""
        return np.sqrt(2 * self.density * self.d_omega)

    def in_hertz(self):
        """The spectrum as MHKiT takes it: an xarray DataArray of S(f) = 2 pi S(w) (m^2/Hz) over f = w / 2 pi (Hz)."""
        import xarray as xr
        return xr.DataArray(2 * math.pi * self.density, dims="Frequency",
                            coords={"Frequency": self.omega / (2 * math.pi)})


@dataclass(frozen=True)
class SpectralMeasures:
    """What the standard characterises a sea state by: significant wave height Hm0 = 4 sqrt(m0) (m), energy period
    Te = m_-1 / m0 (s) and the deep-water energy flux J (W per metre of crest), all of the discrete spectrum."""

    hm0: float
    te: float
    energy_flux: float


def spectral_measures(spectrum: SeaSpectrum) -> SpectralMeasures:
    """Hm0, Te and J of a discrete spectrum by MHKiT (mhkit.wave.resource.significant_wave_height, energy_period,
    energy_flux; the spectrum in hertz, its bins equally spaced).  In deep water the group velocity is g / (2 w), so
    J = rho g sum S(w) c_g dw = rho g^2 / 2 m_-1(w), which MHKiT writes rho g^2 / (64 pi) Hm0^2 Te (deep=True);
    at a finite depth MHKiT sums S c_g df with the group velocity of the dispersion relation."""
    resource, _ = mhkit_wave()
    s_f = spectrum.in_hertz()
    hm0 = float(resource.significant_wave_height(s_f, to_pandas=False))
    te = float(resource.energy_period(s_f, to_pandas=False))
    deep = not spectrum.depth > 0
    # h is not used in deep water; MHKiT asks for a number all the same
    flux = float(resource.energy_flux(s_f, 1.0e4 if deep else float(spectrum.depth), deep=deep,
                                      rho=float(spectrum.rho), g=float(spectrum.g), to_pandas=False))
    return SpectralMeasures(hm0, te, flux)


# ---------------------------------------------------------------- the bins
def confidence_interval(values, confidence: float = CONFIDENCE) -> tuple:
    """(low, high) of the mean of ``values`` (finite numbers, n >= 2): mean -+ t_{(1 + c) / 2, n - 1} s / sqrt(n),
    s the sample standard deviation (n - 1 in its denominator); (nan, nan) for fewer than two values."""
    from scipy.stats import t as student_t
    require(0 < confidence < 1, "confidence", f"got {confidence!r}", "0 < c < 1")
    x = np.asarray(values, float)
    if x.size < 2:
        return math.nan, math.nan
    half = float(student_t.ppf(0.5 * (1 + confidence), x.size - 1) * x.std(ddof=1) / math.sqrt(x.size))
    mean = float(x.mean())
    return mean - half, mean + half


def bin_statistics(powers, energy_flux: float, characteristic_width: float,
                   confidence: float = CONFIDENCE) -> dict:
    """One bin of the power matrix from its runs' mean powers (W; NaN for a failed run, left out): count, mean,
    std (N degrees of freedom, IEC TS 62600-100 formula D.5), min and max of the power (MHKiT's
    wave.performance.statistics), the same of the capture width P / J (m; MHKiT's capture_width), the capture-width
    ratio (mean capture width / characteristic width), and the confidence interval of the mean power."""
    require(math.isfinite(energy_flux) and energy_flux > 0, "energy flux", f"got {energy_flux!r}", "> 0 W/m")
    require(math.isfinite(characteristic_width) and characteristic_width > 0, "characteristic width",
            f"got {characteristic_width!r}", "> 0 m")
    p = np.asarray(powers, float)
    p = p[np.isfinite(p)]
    out = {"count": int(p.size)}
    keys = ("mean", "std", "min", "max")
    if p.size == 0:
        out.update({f"{k}_power_W": math.nan for k in keys})
        out.update({f"{k}_capture_width_m": math.nan for k in keys})
        out.update({"capture_width_ratio": math.nan, "ci_low_W": math.nan, "ci_high_W": math.nan,
                    "ci_half_width_W": math.nan})
        return out
    _, performance = mhkit_wave()
    power_stats = performance.statistics(p, to_pandas=False)
    width = np.asarray(performance.capture_width(p, np.full(p.size, energy_flux), to_pandas=False), float)
    width_stats = performance.statistics(width, to_pandas=False)
    for k in keys:
        out[f"{k}_power_W"] = float(power_stats.sel(index=k))
    for k in keys:
        out[f"{k}_capture_width_m"] = float(width_stats.sel(index=k))
    out["capture_width_ratio"] = out["mean_capture_width_m"] / characteristic_width
    low, high = confidence_interval(p, confidence)
    out.update({"ci_low_W": low, "ci_high_W": high, "ci_half_width_W": 0.5 * (high - low)})
    return out


def check_bins(heights, energy_periods, hs_bin_width: float = IEC_HS_BIN_WIDTH,
               te_bin_width: float = IEC_TE_BIN_WIDTH, runs_per_bin: int | None = None,
               min_runs: int = MIN_RUNS_PER_BIN) -> None:
    """Refuse a grid of sea states whose bins the standard would not accept, before any run: each bin is centred on
    its sea state (Hm0 = the grid's Hs, Te of its spectrum), at most IEC_HS_BIN_WIDTH m by IEC_TE_BIN_WIDTH s; no
    two sea states in one bin (their bins would overlap: the grid's neighbours at least one bin width apart); and
    at least ``min_runs`` runs (seeds) in each bin.  Each refusal is a ParameterError naming the option to change."""
    require(math.isfinite(hs_bin_width) and 0 < hs_bin_width <= IEC_HS_BIN_WIDTH, "hs-bin-width",
            f"got {hs_bin_width!r} m", f"0 < width <= {IEC_HS_BIN_WIDTH:g} m (IEC TS 62600-100)")
    require(math.isfinite(te_bin_width) and 0 < te_bin_width <= IEC_TE_BIN_WIDTH, "te-bin-width",
            f"got {te_bin_width!r} s", f"0 < width <= {IEC_TE_BIN_WIDTH:g} s (IEC TS 62600-100)")
    require(isinstance(min_runs, (int, np.integer)) and min_runs >= 2, "min-runs", f"got {min_runs!r}",
            "an integer >= 2 (the spread over seeds needs two runs)")
    if runs_per_bin is not None:
        require(runs_per_bin >= min_runs, "seeds", f"{runs_per_bin} run(s) per bin",
                f">= {min_runs} per bin (--min-runs)")
    for values, width, option, unit, what in ((heights, hs_bin_width, "hs", "m", "hs-bin-width"),
                                              (energy_periods, te_bin_width, "tp", "s", "te-bin-width")):
        v = np.sort(np.asarray(values, float).ravel())
        gaps = np.diff(v)
        close = np.flatnonzero(gaps < width * (1 - 1e-9))
        if close.size:
            a, b = v[close[0]], v[close[0] + 1]
            name = "Hs" if option == "hs" else "Te"
            raise ParameterError(option, f"{name} {a:.4g} and {b:.4g} {unit} are {b - a:.4g} {unit} apart: two sea "
                                 f"states in one bin of --{what} {width:g} {unit}",
                                 f"sea states whose {name} differ by at least the bin width, or a narrower "
                                 f"--{what}")


def bin_edges(centre: float, width: float) -> tuple:
    """(low, high) of the bin of that width centred on a sea state's value."""
    return centre - 0.5 * width, centre + 0.5 * width
