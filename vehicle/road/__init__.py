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
from .tracks import roads_input, two_tracks, wheel_roads

__all__ = [  # alphabetical: the index of the package
    "BumpRoad",
    "class_limits",
    "class_of",
    "class_psd_n0",
    "classify_profile",
    "DEFAULT_TAPER_M",
    "displacement_psd",
    "driven_road",
    "GOLDEN_CAR",
    "golden_car",
    "international_roughness_index",
    "IRI_SPEED_M_S",
    "IriResult",
    "is_road_file",
    "ISO8608_CLASSES",
    "load_profile",
    "make_road",
    "moving_average",
    "N0",
    "N_BAND",
    "parse_bump",
    "profile_psd",
    "ProfileRoad",
    "random_road",
    "RandomRoad",
    "Road",
    "road_input",
    "road_source",
    "road_table",
    "RoadClass",
    "RoadOptions",
    "roads_input",
    "RunSettings",
    "ShapedBump",
    "SHAPES",
    "SweepRoad",
    "TaperedRoad",
    "track_coherence",
    "two_track_road",
    "two_tracks",
    "wheel_roads",
]
