"""The two tandem-cam parameter sets of a 205/60 R15: the default shape factors and the
enveloping set MF-Swift measured on cleats, against the closed-form cam over a step."""

import numpy as np
import pytest

from bodyvib.cli.main import main
from bodyvib.vehicle.road.contact import (
    CONTACTS,
    basic_function,
    default_tire,
    effective_road,
    load_tire,
)
from bodyvib.vehicle.road.measured import load_profile

H, DX = 0.02, 0.001  # a 20 mm step sampled every millimetre


def _step():
    return np.r_[np.zeros(1000), np.full(1000, H)]


def _predicted_slope(tire):
    """The steepest slope of one cam's envelope of the step, closed form: the cam's lowest
    point rises as ``H - y(d)`` where its contour ``y(d) = b (1 - (1 - (d/a)^c)^(1/c))``
    first touches the edge, ``y(d*) = H``; there ``dw/dx = y'(d*)``, its largest value."""
    a, b, c = tire.half_length, tire.half_height, tire.order
    r = (1.0 - (1.0 - H / b) ** c) ** (1.0 / c)
    return b / a * r ** (c - 1.0) * (1.0 - r**c) ** (1.0 / c - 1.0)


def test_the_measured_set_is_the_property_files():
    """TNO's 2013 MF-Swift file of a 205/60 R15: ELLIPS_LENGTH, ELLIPS_HEIGHT, ELLIPS_ORDER,
    ELLIPS_SHIFT and UNLOADED_RADIUS, typed here from the source."""
    t = load_tire("mfswift-205-60R15")
    assert (t.length_factor, t.height_factor, t.order, t.shift_factor) == (
        1.4634,
        0.9551,
        1.5257,
        0.8328,
    )
    assert t.radius_m == 0.3135 and t.name == "mfswift-205-60R15"
    # the chosen footprint: MF-Swift's contact length at 3424 N on 209651.5 N/m
    d = 3424.0 / 209651.5
    a = 0.3135 * (d / 0.3135 + 0.5 * np.sqrt(d / 0.3135))
    assert t.footprint_m == pytest.approx(2 * a, abs=5e-4)
    assert default_tire().name == "tandem-cam"
    assert "mfswift-205-60R15" in CONTACTS


def test_the_longer_flatter_cam_of_the_measured_set_climbs_a_step_more_gently():
    """The measured cam is 1.46 r0 long and 0.96 r0 high (the default 1 and 1) of order
    1.53 (1.8): it touches the step's edge from further away and rises less steeply. Each
    set's steepest one-cam slope is the closed form's, to the millimetre sampling; the
    tandem's effective road is gentler with the measured set and reaches the top later."""
    sets = {name: load_tire(name) for name in ("tandem-cam", "mfswift-205-60R15")}
    slopes, rises = {}, {}
    for name, tire in sets.items():
        w = basic_function(_step(), DX, tire)
        assert np.max(np.diff(w)) / DX == pytest.approx(_predicted_slope(tire), rel=0.02), name
        eff = effective_road(_step(), DX, tire)
        slopes[name] = np.max(np.diff(eff)) / DX
        rises[name] = DX * np.count_nonzero((eff > 0.05 * H) & (eff < 0.95 * H))
    assert _predicted_slope(sets["mfswift-205-60R15"]) < 0.8 * _predicted_slope(sets["tandem-cam"])
    # one cam: 0.31 against 0.40; the tandem's mean of two cams: 0.26 against 0.31
    assert slopes["mfswift-205-60R15"] < 0.9 * slopes["tandem-cam"]
    assert rises["mfswift-205-60R15"] > rises["tandem-cam"]


def test_a_road_file_is_driven_with_the_set_named(tmp_path, capsys):
    path = tmp_path / "step.csv"
    x = np.arange(2000) * DX
    np.savetxt(path, np.column_stack([x, _step()]), delimiter=",", header="distance,elevation")
    road = load_profile(str(path), contact="mfswift-205-60R15")
    assert road.contact == load_tire("mfswift-205-60R15")
    assert road.describe()["contact"]["name"] == "mfswift-205-60R15"
    assert main(["cosim", "--road", str(path), "--road-contact", "tyre"]) == 2
    err = capsys.readouterr().err
    assert "mfswift-205-60R15" in err and len(err.strip().splitlines()) <= 3
