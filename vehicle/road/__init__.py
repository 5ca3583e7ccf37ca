"""Roads: profiles over distance, and the input a car sees at a speed.

:class:`~bodyvib.vehicle.road.base.Road` is the interface every road implements.
:mod:`~bodyvib.vehicle.road.synthetic` makes roads from a short name: ISO 8608 random
roads of classes A-H (one track, or the two tracks of a car correlated as an isotropic
surface), a bump, a sine sweep, and the speed humps, tables and potholes of
:mod:`~bodyvib.vehicle.road.bumps` (``hump:h=0.075,l=3.7``); it also holds the fade-in
:class:`~bodyvib.vehicle.road.synthetic.TaperedRoad`, the road input at a speed, and the
table that ``Road.fmu`` carries. :mod:`~bodyvib.vehicle.road.measured` reads measured
profiles (OpenCRG, CSV and text columns, ERD) into a :class:`~bodyvib.vehicle.road.profile.ProfileRoad`.
:mod:`~bodyvib.vehicle.road.driven` gives the road every run and ``Road.fmu`` drive: any of
them, faded in from level, so the car starts at rest on it.
:mod:`~bodyvib.vehicle.road.iri` computes a profile's
International Roughness Index (the Golden Car, exactly discretized) and
:mod:`~bodyvib.vehicle.road.classify` its displacement PSD, fitted ISO 8608 line and class;
both take plain ``(distance, elevation)`` arrays.

Import from the package (``from bodyvib.vehicle.road import driven_road``): the names in ``__all__``
are its public interface, and the modules that hold them are internal and may move.
"""

from .base import Road
from .bumps import SHAPES, ShapedBump, parse_bump
from .classify import RoadClass, class_limits, class_of, classify_profile, profile_psd
from .driven import DEFAULT_TAPER_M, RoadOptions, RunSettings, driven_road, is_road_file
from .iri import (
    GOLDEN_CAR,
    IRI_SPEED_M_S,
    IriResult,
    golden_car,
    international_roughness_index,
    moving_average,
)
from .measured import load_profile
from .profile import ProfileRoad
from .synthetic import (
    ISO8608_CLASSES,
    N0,
    N_BAND,
    BumpRoad,
    RandomRoad,
    SweepRoad,
    TaperedRoad,
    class_psd_n0,
    displacement_psd,
    make_road,
    random_road,
    road_input,
    road_source,
    road_table,
    track_coherence,
    two_track_road,
)
from .tracks import roads_input, wheel_roads

__all__ = [
    "ISO8608_CLASSES",
    "N0",
    "N_BAND",
    "class_psd_n0",
    "displacement_psd",
    "Road",
    "RandomRoad",
    "BumpRoad",
    "SweepRoad",
    "TaperedRoad",
    "SHAPES",
    "ShapedBump",
    "parse_bump",
    "random_road",
    "two_track_road",
    "track_coherence",
    "wheel_roads",
    "roads_input",
    "road_source",
    "road_table",
    "make_road",
    "road_input",
    "DEFAULT_TAPER_M",
    "RoadOptions",
    "RunSettings",
    "driven_road",
    "is_road_file",
    "ProfileRoad",
    "load_profile",
    "RoadClass",
    "class_limits",
    "class_of",
    "classify_profile",
    "profile_psd",
    "GOLDEN_CAR",
    "IRI_SPEED_M_S",
    "IriResult",
    "golden_car",
    "international_roughness_index",
    "moving_average",
]
