"""What a road is before it is driven: length, spacing, elevation, ISO 8608 class, IRI.

:func:`summarize_profile` puts together, for plain ``(distance, elevation)``
arrays, the elevation statistics, the displacement PSD and its ISO 8608 fit
(:mod:`bodyvib.vehicle.road.classify`) and the International Roughness Index
(:mod:`bodyvib.vehicle.road.iri`); :func:`format_summary` and :func:`plot_summary` are
its text and its plot (``bodyvib road``).
"""

from dataclasses import dataclass

import numpy as np

from bodyvib.plotting import stacked_panels

from .classify import (
    POOR_FIT_MISFIT,
    RoadClass,
    _fit_band,
    _segments,
    class_limits,
    profile_psd,
)
from .iri import IriResult, _check_profile, international_roughness_index
from .synthetic import ISO8608_CLASSES, N0, class_psd_n0

__all__ = [
    "RoadSummary",
    "TrackSummaries",
    "summarize_profile",
    "format_summary",
    "plot_summary",
]


@dataclass(frozen=True)
class RoadSummary:
    """A profile's description (:func:`summarize_profile`).

    Attributes
    ----------
    name : str
        Label of the road.
    length_m, spacing_m : float
        Extent and sample spacing, m.
    samples : int
        Number of profile points.
    elevation_m : dict
        ``mean``; ``rms``, ``min``, ``max`` about the profile's grade line (least squares),
        and ``range`` of those, m.
    grade : float
        Slope of the least-squares line through the profile (the grade), m/m.
    psd_n : ndarray
        Spatial frequencies of the PSD, cycle/m.
    psd_gd : ndarray
        Displacement PSD, m^3.
    iso8608 : RoadClass
        The ISO 8608 line fitted to the PSD and the class it falls in.
    iri : IriResult
        The International Roughness Index, m/km.
    distance, elevation : ndarray
        The profile (for the plot).
    """

    name: str
    length_m: float
    spacing_m: float
    samples: int
    elevation_m: dict
    grade: float
    psd_n: np.ndarray
    psd_gd: np.ndarray
    iso8608: RoadClass
    iri: IriResult
    distance: np.ndarray
    elevation: np.ndarray

    def to_dict(self, psd: bool = True) -> dict:
        """JSON-ready dict (the PSD as two lists when ``psd``; no profile)."""
        d = {
            "name": self.name,
            "length_m": self.length_m,
            "spacing_m": self.spacing_m,
            "samples": self.samples,
            "elevation_m": dict(self.elevation_m),
            "grade": self.grade,
            "iso8608": self.iso8608.to_dict(),
            "iri": self.iri.to_dict(),
        }
        if psd:
            d["psd"] = {"n_cycles_per_m": self.psd_n.tolist(), "gd_m3": self.psd_gd.tolist()}
        return d


@dataclass(frozen=True)
class TrackSummaries:
    """Summaries of several tracks of one road (an OpenCRG surface's wheel paths).

    Attributes
    ----------
    summaries : tuple of RoadSummary
        One per track, in the order asked.
    """

    summaries: tuple

    def to_dict(self, psd: bool = True) -> dict:
        """JSON-ready dict: ``{"tracks": [summary, ...]}``."""
        return {"tracks": [s.to_dict(psd) for s in self.summaries]}

    def format(self) -> str:
        """The tracks' texts (:func:`format_summary`), a blank line between them."""
        return "\n\n".join(format_summary(s) for s in self.summaries)

    def plot(self, path) -> None:
        """The tracks' profiles over distance and their PSDs, in one figure."""
        with stacked_panels(path) as (ax1, ax2):
            for s in self.summaries:
                ax1.plot(s.distance, 1000 * s.elevation, lw=0.6, label=s.name)
                ax2.loglog(
                    s.psd_n,
                    s.psd_gd,
                    lw=0.6,
                    label=f"{s.name}: class "
                    f"{s.iso8608.iso8608_class}, IRI {s.iri.iri_m_per_km:.2f} m/km",
                )
            ax1.set_xlabel("distance [m]")
            ax1.set_ylabel("elevation [mm]")
            ax1.grid(True, alpha=0.3)
            ax1.legend(fontsize=8)
            ax2.set_xlabel("spatial frequency n [cycle/m]")
            ax2.set_ylabel("Gd(n) [m^3]")
            ax2.grid(True, which="both", alpha=0.3)
            ax2.legend(fontsize=8, loc="lower left")


def summarize_profile(distance, elevation, name: str = "profile") -> RoadSummary:
    """Elevation statistics, ISO 8608 class and IRI of a uniformly spaced profile.

    Parameters
    ----------
    distance : (n,) array_like
        Distances, m, at a constant spacing.
    elevation : (n,) array_like
        Heights, m.
    name : str
        Label.

    Returns
    -------
    RoadSummary

    Raises
    ------
    BodyvibError
        A bad profile (see :func:`bodyvib.vehicle.road.iri.international_roughness_index`)
        or one that resolves too little of ISO 8608's band to be classed.

    Examples
    --------
    >>> from bodyvib.vehicle.road.synthetic import random_road
    >>> x = np.arange(0, 300, 0.05)
    >>> s = summarize_profile(x, random_road("B", 300.05, seed=1).displacement(x))
    >>> s.iso8608.iso8608_class, s.samples
    ('B', 6000)
    """
    x, z, dx = _check_profile(distance, elevation)
    grade, offset = np.polyfit(x - x[0], z, 1)
    r = z - offset - grade * (x - x[0])  # about the grade line: the roughness
    stats = {
        "mean": float(z.mean()),
        "rms": float(np.sqrt(np.mean(r**2))),
        "min": float(r.min()),
        "max": float(r.max()),
        "range": float(r.max() - r.min()),
    }
    n, gd, segment = profile_psd(x, z)  # one Welch PSD, shown and fitted
    return RoadSummary(
        name=str(name),
        length_m=float(x[-1] - x[0]),
        spacing_m=dx,
        samples=int(x.size),
        elevation_m=stats,
        grade=float(grade),
        psd_n=n,
        psd_gd=gd,
        iso8608=_fit_band(n, gd, segment, segments=_segments(x, segment)),
        iri=international_roughness_index(x, z),
        distance=x,
        elevation=z,
    )


def format_summary(s: RoadSummary) -> str:
    """The summary as the text ``bodyvib road`` prints.

    Parameters
    ----------
    s : RoadSummary
        From :func:`summarize_profile`; its elevations (m) are printed in mm.

    Returns
    -------
    str
        The lines (no trailing newline): the name; length, spacing and samples; the
        grade; elevation statistics about the grade line in mm; the ISO 8608 fit, its
        band, class and fit quality (and a warning line when the line does not fit);
        the IRI in m/km with the moving average it applied.
    """
    e = {k: 1000 * v for k, v in s.elevation_m.items()}
    c = s.iso8608
    lo, hi = c.class_limits_m3
    limits = f"{lo:.3g}-{hi:.3g}" if np.isfinite(hi) else f">= {lo:.3g}"
    band = f"{c.band_cycles_per_m[0]:.3g}-{c.band_cycles_per_m[1]:.3g} cycle/m"
    wave = (
        f"waviness w = {c.waviness:.2f} (fitted over {band})"
        if c.waviness_fitted
        else f"waviness w = 2 (ISO 8608's, held: the band {band} does not reach n0)"
    )
    k = s.iri.smoothing_samples
    smoothing = (
        f"{k}-sample {1000 * k * s.spacing_m:.4g} mm moving average"
        if k > 1
        else f"no moving average at a {s.spacing_m:.6g} m spacing"
    )
    lines = [
        f"road {s.name}",
        f"length {s.length_m:.6g} m, spacing {s.spacing_m:.6g} m ({s.samples} samples)",
        f"grade {round(100 * s.grade, 3) + 0.0:+.3f} % (least-squares line; removed for the "
        "statistics)",
        f"elevation about the grade line: r.m.s. {e['rms']:.2f} mm, min {e['min']:.2f} mm, "
        f"max {e['max']:.2f} mm (mean elevation {s.elevation_m['mean']:.3f} m)",
        f"ISO 8608: Gd(n0 = 0.1 cycle/m) = {c.gd_n0_m3:.3g} m^3, {wave} -> class "
        f"{c.iso8608_class} ({limits} m^3); band means within a factor {c.scatter:.2f} of the "
        f"line (misfit {c.misfit:.2f} of their own scatter)",
    ]
    if not c.fits:
        lines.append(
            f"warning: the ISO 8608 line fits this profile badly (misfit {c.misfit:.3g} > "
            f"{POOR_FIT_MISFIT:g}): its PSD is not a straight line in log-log axes (a "
            "periodic profile?), and the class describes it poorly"
        )
    lines.append(
        f"IRI {s.iri.iri_m_per_km:.3f} m/km (Golden Car at 80 km/h over {s.iri.length_m:.6g} "
        f"m, {smoothing})"
    )
    return "\n".join(lines)


def plot_summary(s: RoadSummary, path) -> None:
    """Profile over distance, and its PSD against the ISO 8608 class limits.

    Parameters
    ----------
    s : RoadSummary
        From :func:`summarize_profile`: its profile goes on top, its PSD, band means and
        fitted line below, against the class limits.
    path : str or os.PathLike
        Plot file (.png, .pdf or .svg).

    Raises
    ------
    BodyvibError
        An unsupported plot file extension.
    """
    with stacked_panels(path) as (ax1, ax2):
        ax1.plot(s.distance, 1000 * s.elevation, lw=0.6)
        ax1.set_xlabel("distance [m]")
        ax1.set_ylabel("elevation [mm]")
        ax1.set_title(f"{s.name}: IRI {s.iri.iri_m_per_km:.2f} m/km")
        ax1.grid(True, alpha=0.3)
        n = np.geomspace(0.01, 3.0, 50)
        for _i, c in enumerate(ISO8608_CLASSES):  # class limits: twice each geometric mean
            if c != "H":
                ax2.loglog(n, class_limits(c)[1] * (n / N0) ** -2, color="0.6", lw=0.7)
            ax2.text(0.0105, class_psd_n0(c) * (0.0105 / N0) ** -2, c, color="0.4", va="center")
        ax2.loglog(s.psd_n, s.psd_gd, lw=0.6, label="Welch PSD")
        r = s.iso8608
        ax2.loglog(r.band_centres, r.band_gd, "o", ms=4, label="one-third-octave means")
        band = np.geomspace(*r.band_cycles_per_m, 20)
        ax2.loglog(
            band,
            r.gd_n0_m3 * (band / N0) ** -r.waviness,
            "k--",
            label=f"fit: Gd(n0) = {r.gd_n0_m3:.3g} m^3, w = {r.waviness:.2f} "
            f"(class {r.iso8608_class})",
        )
        ax2.set_xlim(0.01, 3.0)
        # every class in view: A's lower half at 3 cycle/m to H's upper limit at 0.01 cycle/m
        low = min(class_psd_n0("A") / 2 * (3.0 / N0) ** -2, float(np.min(r.band_gd)) / 3)
        high = max(2 * class_psd_n0("H") * (0.01 / N0) ** -2, 3 * float(np.max(r.band_gd)))
        ax2.set_ylim(low, high)
        ax2.set_xlabel("spatial frequency n [cycle/m]")
        ax2.set_ylabel("Gd(n) [m^3]")
        ax2.grid(True, which="both", alpha=0.3)
        ax2.legend(fontsize=8, loc="lower left")
