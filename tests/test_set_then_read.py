"""Every shipped SSP in a master that sets inputs and then reads outputs (OMSimulator's order).

``examples/ssp_set_then_read.py`` steps every FMU, then sweeps the connections -- read the
start, set the end -- until no value changes, so a feedthrough output (the body's seat
force, the controller's actuator force) is read with the inputs in force at that point.
Each package runs 5 s at 1 ms in its own process against its monolithic reference on the
road its road FMU carries; the NRMSE of the head acceleration must be within the target
of the Jacobi hosts (0.06 %, tests/test_ssp.py). The active packages with pythonfmu
FMUs (``bodyvib build --control``) are built here and held to the issue's 0.1 % against
the exact closed loop; the native active packages are in tests/test_active.py (their
fixtures build them).
"""

import pytest

from bodyvib.vehicle.reference import nrmse
from bodyvib.vehicle.ssp import FULL_CAR_SSP_NAME, HALF_CAR_SSP_NAME, SSP_NAME, ssp_reference

pytestmark = pytest.mark.integration

HOST = "ssp_set_then_read"

#: (fixture of the build folder, package path in it, car of its reference)
PACKAGES = {
    "pythonfmu": ("python_fmu_dir", f"{SSP_NAME}.ssp", "quarter-car"),
    "native": ("native_dist", f"{SSP_NAME}.ssp", "quarter-car"),
    "native-fmi3": ("native_dist", f"fmi3/{SSP_NAME}.ssp", "quarter-car"),
    "native-half": ("native_dist", f"{HALF_CAR_SSP_NAME}.ssp", "half-car"),
    "native-half-fmi3": ("native_dist", f"fmi3/{HALF_CAR_SSP_NAME}.ssp", "half-car"),
    "native-full": ("native_dist", f"{FULL_CAR_SSP_NAME}.ssp", "full-car"),
    "native-full-fmi3": ("native_dist", f"fmi3/{FULL_CAR_SSP_NAME}.ssp", "full-car"),
}


@pytest.mark.parametrize("package", list(PACKAGES))
def test_every_package_runs_within_the_target_when_inputs_are_set_first(request, package):
    """Measured 0.008 % (native quarter car); every package below the 0.06 % target."""
    from test_ssp import TARGET, host_run

    fixture, path, car = PACKAGES[package]
    res, _ = host_run(HOST, request.getfixturevalue(fixture) / path, duration=5.0)
    ref = ssp_reference(5.0, 1e-3, car=car)["head_acceleration"]
    head = res["Body.head_acceleration"]
    assert head.size == ref.size
    assert nrmse(head, ref) <= TARGET, nrmse(head, ref)
    assert res["sweeps"].max() <= 5  # the loop through the seat settles at once


@pytest.fixture(scope="module")
def python_active(tmp_path_factory):
    """``bodyvib build --control skyhook [--car half-car-active|full-car-active]``:
    pythonfmu road, car and body with the native controller, as a user builds them."""
    from bodyvib.cli.main import main

    dest = tmp_path_factory.mktemp("python_active")
    for car in ("quarter-car-active", "half-car-active", "full-car-active"):
        argv = ["build", "--control", "skyhook", "--car", car, "--dest", str(dest / car)]
        assert main(argv) == 0
    return dest


@pytest.mark.parametrize(
    "car, package",
    [
        ("quarter-car-active", "ActiveQuarterCarWithOccupant"),
        ("half-car-active", "ActiveHalfCarWithOccupant"),
        ("full-car-active", "ActiveFullCarWithOccupant"),
    ],
)
def test_active_pythonfmu_packages_run_within_the_target(python_active, car, package):
    """The controller is handed the car's velocities at the current point and gives the law
    of those: measured 0.016 % (quarter car) against the closed loop, the issue's target
    0.1 % (0.83 % with a controller that extrapolated what it was just handed)."""
    from test_ssp import host_run

    from bodyvib.vehicle.control import parse_control
    from bodyvib.vehicle.quarter_car import load_car

    ssp = python_active / car / "active" / f"{package}.ssp"
    res, _ = host_run(HOST, ssp, duration=5.0)
    law = parse_control("skyhook", load_car(car))
    ref = ssp_reference(5.0, 1e-3, car=car, controller=law)["head_acceleration"]
    assert nrmse(res["Body.head_acceleration"], ref) <= 1e-3, nrmse(
        res["Body.head_acceleration"], ref
    )
