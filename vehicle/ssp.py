"""The coupled system as an SSP 1.0 package: road, car and occupant, wired.

``python build_fmu.py`` writes ``dist/QuarterCarWithOccupant.ssp`` with
:func:`write_ssp`: ``SystemStructure.ssd``, the three FMUs under ``resources/``,
the parameter set (every parameter at its baked-in value, one ``.ssv`` per
component, ``resources/<component>.ssv``, bound to it without a prefix: libcosim
ignores a binding's prefix) and the default experiment. Any SSP host (libcosim, Ecos, fmpy's SSP runner) runs it without a
line of coupling code.

The connections are what a correct coupling needs in a host that steps all
FMUs in parallel and holds every input over a step (libcosim, Ecos, fmpy.ssp):

* ``Road.road_displacement``, ``Road.road_velocity`` -> ``Car``: the car's road
  rises at the road velocity over the step, as in the monolithic reference;
* ``Car.seat_displacement``, ``Car.seat_velocity``, ``Car.sprung_acceleration``
  -> ``Body``: the seat follows the parabola of its displacement, velocity and
  acceleration over the step, so the seat force the body reports right after
  the step is that of (nearly) the car's seat (with a line only it misses the
  seat by ``a h^2 / 2``, which the stiff seat feeds straight into the force);
* ``Body.seat_force``, ``Body.seat_force_rate`` -> ``Car``: the seat force rises
  at its exact rate over the step (without the rate it is held, first order).

The half car's package, ``HalfCarWithOccupant.ssp`` (:data:`HALF_CAR_COMPONENTS`), wires
``RoadFrontRear``'s two road pairs to the ``HalfCar``'s front and rear road inputs and the
occupant the same way; the full car's, ``FullCarWithOccupant.ssp``
(:data:`FULL_CAR_COMPONENTS`), ``RoadFourWheel``'s four pairs (left and right tracks, the
rear a wheelbase behind) to the ``FullCar``'s four corners.

Measured head-acceleration errors per host: docs/tutorials/fmu_hosts.md,
"Co-simulation in any host (SSP)".
"""

import io
import zipfile
from pathlib import Path
from typing import Dict, Optional, Sequence, Tuple
from xml.etree import ElementTree as ET

import numpy as np

from bodyvib.process.outputs import atomic_write_bytes, staged_source
from bodyvib.process.progress import Progress, progress_lines
from bodyvib.runtime.contract import UNITS
from bodyvib.runtime.renames import renamed_parameters

__all__ = [
    "SSP_NAME",
    "CONNECTIONS",
    "COMPONENTS",
    "HALF_CAR_SSP_NAME",
    "HALF_CAR_COMPONENTS",
    "HALF_CAR_CONNECTIONS",
    "FULL_CAR_SSP_NAME",
    "FULL_CAR_COMPONENTS",
    "FULL_CAR_CONNECTIONS",
    "ACTIVE_SSP_NAME",
    "ACTIVE_COMPONENTS",
    "ACTIVE_CONNECTIONS",
    "ACTIVE_HALF_CAR_SSP_NAME",
    "ACTIVE_HALF_CAR_COMPONENTS",
    "ACTIVE_FULL_CAR_SSP_NAME",
    "ACTIVE_FULL_CAR_COMPONENTS",
    "ACTIVE_FULL_CAR_CONNECTIONS",
    "ACTIVE_HALF_CAR_CONNECTIONS",
    "ACTIVE_PACKAGES",
    "build_active_ssp",
    "PACKAGES",
    "parameter_values",
    "ssp_parameters",
    "ssp_reference",
    "system_structure",
    "write_ssp",
]

#: The package's name (``<SSP_NAME>.ssp``, the system, the parameter set).
SSP_NAME = "QuarterCarWithOccupant"

#: Component name -> FMU name of :data:`bodyvib.vehicle.fmus.FMUS` (the body may be any body FMU).
COMPONENTS = {"Road": "Road", "Car": "QuarterCar", "Body": "HumanBody3DOF"}

#: The half car's package: road under both axles, half car, occupant.
HALF_CAR_SSP_NAME = "HalfCarWithOccupant"

#: Component name -> FMU name of the half car's package.
HALF_CAR_COMPONENTS = {"Road": "RoadFrontRear", "Car": "HalfCar", "Body": "HumanBody3DOF"}

#: The full car's package: road under the four wheels, full car, occupant.
FULL_CAR_SSP_NAME = "FullCarWithOccupant"

#: Component name -> FMU name of the full car's package.
FULL_CAR_COMPONENTS = {"Road": "RoadFourWheel", "Car": "FullCar", "Body": "HumanBody3DOF"}

#: One connection: (start element, start connector, end element, end connector).
Connection = Tuple[str, str, str, str]

#: The quarter car's connections.
CONNECTIONS = (
    ("Road", "road_displacement", "Car", "road_displacement"),
    ("Road", "road_velocity", "Car", "road_velocity"),
    ("Car", "seat_displacement", "Body", "seat_displacement"),
    ("Car", "seat_velocity", "Body", "seat_velocity"),
    ("Car", "sprung_acceleration", "Body", "seat_acceleration"),
    ("Body", "seat_force", "Car", "seat_force"),
    ("Body", "seat_force_rate", "Car", "seat_force_rate"),
)


def _wheel_connections(wheels):
    """A road pair per wheel suffix from the road FMU to the car, then the occupant."""
    return tuple(
        ("Road", f"road_{q}_{w}", "Car", f"road_{q}_{w}")
        for w in wheels
        for q in ("displacement", "velocity")
    ) + tuple(c for c in CONNECTIONS if c[0] != "Road")


#: The half car's connections: a road pair per axle, then the occupant as on the quarter car.
HALF_CAR_CONNECTIONS = _wheel_connections(("front", "rear"))

#: The full car's connections: a road pair per wheel (the names of FullCar's road
#: inputs), then the occupant as on the quarter car.
FULL_CAR_CONNECTIONS = _wheel_connections(("front_left", "front_right", "rear_left", "rear_right"))


def _controller_connections(suffixes):
    """Per actuator suffix: the car's motion to the controller, its force back to the car."""
    wires = ()
    for s in suffixes:
        wires += tuple(
            ("Car", f"actuator_{q}{s}", "Controller", f"{q}{s}")
            for q in (
                "upper_velocity",
                "lower_velocity",
                "upper_acceleration",
                "lower_acceleration",
            )
        )
        wires += tuple(
            ("Controller", f"{q}{s}", "Car", f"{q}{s}")
            for q in ("actuator_force", "actuator_force_rate")
        )
    return wires


#: The active package: the quarter car with an actuator, driven by a skyhook controller.
ACTIVE_SSP_NAME = "ActiveQuarterCarWithOccupant"

#: Component name -> FMU name of the active package (the car built from
#: ``quarter-car-active``, the controller from :mod:`bodyvib.fmu.controller`).
ACTIVE_COMPONENTS = dict(COMPONENTS, Controller="SkyhookController")

#: The quarter car's connections, and the controller between the car's actuator velocities
#: and accelerations and its actuator force and force rate. A Jacobi host hands the
#: controller the car's motion of the previous communication point: the controller
#: extrapolates the velocities over the step with the accelerations, and the rate gives
#: the force its slope over the next step.
ACTIVE_CONNECTIONS = CONNECTIONS + _controller_connections(("",))

#: The active half car's package: the half car with an actuator per axle.
ACTIVE_HALF_CAR_SSP_NAME = "ActiveHalfCarWithOccupant"

#: Component name -> FMU name of the active half car's package (the car built from
#: ``half-car-active``, the controller for the suffixes ``_front`` and ``_rear``).
ACTIVE_HALF_CAR_COMPONENTS = dict(HALF_CAR_COMPONENTS, Controller="SkyhookController")

#: The half car's connections, and the controller wired per axle as on the quarter car.
ACTIVE_HALF_CAR_CONNECTIONS = HALF_CAR_CONNECTIONS + _controller_connections(("_front", "_rear"))

#: The active full car's package: the full car with an actuator per corner.
ACTIVE_FULL_CAR_SSP_NAME = "ActiveFullCarWithOccupant"

#: Component name -> FMU name of the active full car's package (the car built from
#: ``full-car-active``, the controller for the suffixes ``_front_left`` ... ``_rear_right``).
ACTIVE_FULL_CAR_COMPONENTS = dict(FULL_CAR_COMPONENTS, Controller="SkyhookController")

#: The full car's connections, and the controller wired per corner as on the quarter car.
ACTIVE_FULL_CAR_CONNECTIONS = FULL_CAR_CONNECTIONS + _controller_connections(
    ("_front_left", "_front_right", "_rear_left", "_rear_right")
)

#: Package name -> (components, connections, description of the system).
PACKAGES = {
    SSP_NAME: (
        COMPONENTS,
        CONNECTIONS,
        "Quarter car on a road with a seated occupant, two-way coupled through seat motion "
        "and seat force (and their rates)",
    ),
    HALF_CAR_SSP_NAME: (
        HALF_CAR_COMPONENTS,
        HALF_CAR_CONNECTIONS,
        "Half car (bounce and pitch) on a road under both axles with a seated occupant, "
        "two-way coupled through seat motion and seat force (and their rates)",
    ),
    FULL_CAR_SSP_NAME: (
        FULL_CAR_COMPONENTS,
        FULL_CAR_CONNECTIONS,
        "Full car (bounce, pitch and roll) on a two-track road under its four wheels with a "
        "seated occupant, two-way coupled through seat motion and seat force (and their "
        "rates)",
    ),
    ACTIVE_SSP_NAME: (
        ACTIVE_COMPONENTS,
        ACTIVE_CONNECTIONS,
        "Quarter car with an actuator on a road with a seated occupant; a skyhook/groundhook "
        "controller sets the actuator force from the car's body and wheel velocities",
    ),
    ACTIVE_HALF_CAR_SSP_NAME: (
        ACTIVE_HALF_CAR_COMPONENTS,
        ACTIVE_HALF_CAR_CONNECTIONS,
        "Half car with an actuator per axle on a road under both axles with a seated "
        "occupant; a skyhook/groundhook controller sets each actuator force from the "
        "body and wheel velocities at its axle",
    ),
    ACTIVE_FULL_CAR_SSP_NAME: (
        ACTIVE_FULL_CAR_COMPONENTS,
        ACTIVE_FULL_CAR_CONNECTIONS,
        "Full car with an actuator per corner on a two-track road under its four wheels with "
        "a seated occupant; a skyhook/groundhook controller sets each actuator force from "
        "the body and wheel velocities at its corner",
    ),
}

#: Car FMU name (:func:`bodyvib.vehicle.fmus.car_fmu_name`) -> its active package's name.
ACTIVE_PACKAGES = {
    "QuarterCar": ACTIVE_SSP_NAME,
    "HalfCar": ACTIVE_HALF_CAR_SSP_NAME,
    "FullCar": ACTIVE_FULL_CAR_SSP_NAME,
}

_NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
}
for _p, _u in _NS.items():
    ET.register_namespace(_p, _u)


def _q(prefix, tag):
    return f"{{{_NS[prefix]}}}{tag}"


def _variables(fmu_path):
    """(name, causality, unit, start) of an FMU's real variables (FMI 2.0 or 3.0)."""
    with zipfile.ZipFile(staged_source(fmu_path)) as zf:  # built in this block: staged
        root = ET.fromstring(zf.read("modelDescription.xml"))
    out = []
    for sv in root.find("ModelVariables"):
        if sv.tag == "ScalarVariable" and sv.find("Real") is not None:  # FMI 2.0
            real = sv.find("Real")
            out.append((sv.get("name"), sv.get("causality"), real.get("unit"), real.get("start")))
        elif sv.tag == "Float64" and sv.get("causality") != "independent":  # FMI 3.0
            out.append((sv.get("name"), sv.get("causality"), sv.get("unit"), sv.get("start")))
    return out


def ssp_parameters(fmu_path):
    """One component's parameter set: ``(parameter, value, unit)`` at the FMU's start values.

    Parameters
    ----------
    fmu_path : str
        ``.fmu`` file (FMI 2.0 or 3.0); one written earlier in the same staged-writes
        block is read from its staged copy.

    Returns
    -------
    list of (str, float, str)
        Name, start value (in that unit) and unit of each parameter, in
        model-description order.
    """
    return [
        (name, float(start), unit)
        for name, causality, unit, start in _variables(fmu_path)
        if causality == "parameter"
    ]


def _units(root_parent, tag_prefix, used):
    units = ET.SubElement(root_parent, _q(tag_prefix, "Units"))
    for u in used:
        unit = ET.SubElement(units, _q("ssc", "Unit"), name=u)
        ET.SubElement(unit, _q("ssc", "BaseUnit"), {k: str(e) for k, e in UNITS[u].items()})


@renamed_parameters(stop_time="duration")
def system_structure(
    fmus: Dict[str, str],
    duration: float = 30.0,
    step: float = 1e-3,
    connections: Sequence[Connection] = CONNECTIONS,
    name: str = SSP_NAME,
) -> bytes:
    """``SystemStructure.ssd`` of the coupled system.

    Parameters
    ----------
    fmus : dict of str to str
        Component name -> FMU path (read for connector units).
    duration : float
        Default experiment's stop time (it starts at 0), s.
    step : float
        Communication step suggested to hosts that read it (libcosim's OSP
        annotation), s.
    connections : sequence of (str, str, str, str)
        :data:`CONNECTIONS` (a subset only to show what a missing one costs), or
        :data:`HALF_CAR_CONNECTIONS`.
    name : str
        A key of :data:`PACKAGES`: the system's name and description.

    Returns
    -------
    bytes
        UTF-8 XML.
    """
    root = ET.Element(
        _q("ssd", "SystemStructureDescription"),
        version="1.0",
        name=name,
        generationTool="bodyvib (bodyvib.vehicle.ssp)",
    )
    system = ET.SubElement(
        root,
        _q("ssd", "System"),
        name=name,
        description=PACKAGES[name][2],
    )
    elements = ET.SubElement(system, _q("ssd", "Elements"))
    used = []
    for comp, path in fmus.items():
        el = ET.SubElement(
            elements,
            _q("ssd", "Component"),
            name=comp,
            type="application/x-fmu-sharedlibrary",
            source=f"resources/{Path(path).name}",
        )
        conns = ET.SubElement(el, _q("ssd", "Connectors"))
        for name, causality, unit, _ in _variables(path):
            if causality in ("input", "output"):
                c = ET.SubElement(conns, _q("ssd", "Connector"), name=name, kind=causality)
                ET.SubElement(c, _q("ssc", "Real"), unit=unit)
                if unit not in used:
                    used.append(unit)
        binds = ET.SubElement(el, _q("ssd", "ParameterBindings"))
        ET.SubElement(binds, _q("ssd", "ParameterBinding"), source=f"resources/{comp}.ssv")
    wires = ET.SubElement(system, _q("ssd", "Connections"))
    for a, ac, b, bc in connections:
        ET.SubElement(
            wires,
            _q("ssd", "Connection"),
            startElement=a,
            startConnector=ac,
            endElement=b,
            endConnector=bc,
        )
    _units(root, "ssd", used)
    experiment = ET.SubElement(
        root, _q("ssd", "DefaultExperiment"), startTime="0.0", stopTime=repr(float(duration))
    )
    annotations = ET.SubElement(experiment, _q("ssd", "Annotations"))  # libcosim's step
    ann = ET.SubElement(annotations, _q("ssc", "Annotation"), type="com.opensimulationplatform")
    alg = ET.SubElement(ann, _q("osp", "Algorithm"))
    ET.SubElement(alg, _q("osp", "FixedStepAlgorithm"), baseStepSize=repr(float(step)))
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def parameter_values(fmu_path, name: str = SSP_NAME) -> bytes:
    """The ``.ssv`` parameter set of one component (:func:`ssp_parameters`).

    Parameters
    ----------
    fmu_path : str
        ``.fmu`` file, as for :func:`ssp_parameters`.
    name : str
        The package's name (a key of :data:`PACKAGES`).

    Returns
    -------
    bytes
        UTF-8 XML: a ``ParameterSet`` named ``name`` with one ``Real`` per
        parameter (value and unit) and the units' SI base units.
    """
    root = ET.Element(_q("ssv", "ParameterSet"), version="1.0", name=name)
    params = ET.SubElement(root, _q("ssv", "Parameters"))
    used = []
    for name, value, unit in ssp_parameters(fmu_path):
        p = ET.SubElement(params, _q("ssv", "Parameter"), name=name)
        ET.SubElement(p, _q("ssv", "Real"), value=repr(value), unit=unit)
        if unit not in used:
            used.append(unit)
    _units(root, "ssv", used)
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


@renamed_parameters(stop_time="duration")
def write_ssp(
    path,
    fmus: Dict[str, str],
    duration: float = 30.0,
    step: float = 1e-3,
    connections: Optional[Sequence[Connection]] = None,
    name: str = SSP_NAME,
) -> Path:
    """Write the SSP of the coupled system.

    Parameters
    ----------
    path : str or path
        ``.../QuarterCarWithOccupant.ssp`` (or ``HalfCarWithOccupant.ssp``).
    fmus : dict of str to str
        Component name (``Road``, ``Car``, ``Body``) -> FMU path.
    duration, step : float
        See :func:`system_structure`.
    connections : sequence of (str, str, str, str), optional
        The package's own (:data:`PACKAGES`) by default.
    name : str
        A key of :data:`PACKAGES`.

    Returns
    -------
    Path
    """
    connections = PACKAGES[name][1] if connections is None else connections
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr(
            "SystemStructure.ssd", system_structure(fmus, duration, step, connections, name)
        )
        for comp, fmu in fmus.items():
            zf.writestr(f"resources/{comp}.ssv", parameter_values(fmu, name))
            zf.write(staged_source(fmu), f"resources/{Path(fmu).name}")
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


def ssp_reference(
    duration: float = 30.0,
    step: float = 1e-3,
    body: str = "reduced-paper",
    car: str = "quarter-car",
    road: Optional[dict] = None,
    controller=None,
) -> Dict[str, np.ndarray]:
    """The monolithic reference of the SSP's system on the road its ``Road.fmu`` carries.

    Parameters
    ----------
    duration, step : float
        s.
    body : str
        Body model baked into the SSP's body FMU.
    car : str
        Vehicle model of its car FMU (``QuarterCar.fmu``, ``HalfCar.fmu`` with
        ``RoadFrontRear.fmu``: the half car's package, or ``FullCar.fmu`` with
        ``RoadFourWheel.fmu``: the full car's).
    road : dict, optional
        The keyword arguments its ``Road.fmu`` was built with
        (:data:`bodyvib.vehicle.fmus.ROAD_DEFAULTS` by default); ``speed`` is the run's.
    controller : bodyvib.vehicle.control.SkyhookController, optional
        The law of the active package's controller: the reference is the closed loop.

    Returns
    -------
    dict of str to ndarray
        :func:`bodyvib.vehicle.reference.reference_run` on ``t = 0, step, ...`` with the
        road samples the FMU outputs (its table, evaluated as the FMU does).
    """
    from bodyvib.models import load_model

    from .fmus import WHEEL_ROAD_CARS, _source, car_fmu_name, fmu_road_of, road_with_defaults
    from .quarter_car import load_car
    from .reference import reference_run
    from .road.synthetic import road_table

    r = road_with_defaults(road)
    wheel_road = [n for n, (fmu, _) in WHEEL_ROAD_CARS.items() if fmu == car_fmu_name(car)]
    if wheel_road:  # RoadFrontRear.fmu's or RoadFourWheel.fmu's table: a column per wheel
        _, table = _source(wheel_road[0], car, **r)
    else:
        table = road_table(*fmu_road_of(r))
    t = np.arange(int(round(duration / step)) + 1) * step
    z, dz = table.evaluate(r["speed"] * t)
    if z.shape[1] == 1:
        z, dz = z[:, 0], dz[:, 0]
    return reference_run(
        load_car(car), load_model(body), z, r["speed"] * dz, step, controller=controller
    )


@renamed_parameters(echo="progress")
def build_active_ssp(
    dest,
    controller,
    road: Optional[dict] = None,
    native: bool = False,
    platforms=None,
    progress: Progress = False,
    car: str = "quarter-car-active",
) -> Path:
    """Build an active package: its four FMUs and the ``.ssp`` wiring them.

    For a quarter car (``quarter-car-active`` by default): ``Road.fmu``, ``QuarterCar.fmu``
    (the inputs ``actuator_force`` and ``actuator_force_rate``, the outputs
    ``actuator_upper_velocity``, ``actuator_lower_velocity`` and their accelerations),
    ``HumanBody3DOF.fmu`` (pythonfmu, or native with ``native``) and
    ``SkyhookController.fmu`` (always native C, FMI 2.0), wired by
    :data:`ACTIVE_CONNECTIONS` into ``ActiveQuarterCarWithOccupant.ssp``. For a half car
    (``half-car-active``): ``RoadFrontRear.fmu`` and ``HalfCar.fmu`` instead, the
    controller built for the car's actuator suffixes (``_front``, ``_rear``), wired by
    :data:`ACTIVE_HALF_CAR_CONNECTIONS` into ``ActiveHalfCarWithOccupant.ssp``. For a full
    car (``full-car-active``): ``RoadFourWheel.fmu`` and ``FullCar.fmu``, a controller
    channel per corner, wired by :data:`ACTIVE_FULL_CAR_CONNECTIONS` into
    ``ActiveFullCarWithOccupant.ssp``.

    Parameters
    ----------
    dest : str or path
        Output folder.
    controller : bodyvib.vehicle.control.SkyhookController
        The law baked into the controller's parameters.
    road : dict, optional
        Options of the road FMU (:data:`bodyvib.vehicle.fmus.ROAD_DEFAULTS` by default).
    native : bool
        Native C FMUs for road, car and body (FMI 2.0).
    platforms : iterable of str, optional
        Native binaries to compile (:data:`bodyvib.fmu.native.PLATFORMS`).
    progress : bool or callable
        One line per file written: on stderr (True) or to a callable (``echo`` still
        works for one release, with a ``DeprecationWarning``).
    car : str
        Vehicle model with actuators (shipped name or parameter file).

    Returns
    -------
    Path
        The ``.ssp`` file.

    Raises
    ------
    BodyvibError
        A car without actuators, or what the FMU builders refuse.
    """
    from bodyvib.fmu.controller import build_controller_fmu
    from bodyvib.process import interrupts
    from bodyvib.process.outputs import staged_writes
    from bodyvib.runtime.contract import actuator_variables

    from .control import check_actuated
    from .fmus import build_fmus, car_fmu_name
    from .quarter_car import load_car

    network = load_car(car)
    check_actuated(network)
    suffixes = tuple(names[0][len("actuator_force") :] for names in actuator_variables(network))
    name = ACTIVE_PACKAGES[car_fmu_name(car)]
    components = PACKAGES[name][0]
    dest = Path(dest)
    lines = []
    with staged_writes(guard=interrupts.critical):  # the FMUs and the package, or nothing
        built = build_fmus(
            dest,
            None,
            car,
            names=[components[c] for c in ("Road", "Car", "Body")],
            progress=lines.append,
            road=road,
            native=native,
            fmi=(2,),
            platforms=platforms,
        )
        built["SkyhookController"] = build_controller_fmu(
            dest,
            suffixes,
            controller.c_sky,
            controller.c_ground,
            controller.semi_active,
            platforms=platforms,
        )
        lines.append(f"wrote {built['SkyhookController']} (native C, FMI 2.0, the law's gains)")
        path = write_ssp(
            dest / f"{name}.ssp",
            {comp: str(built[fmu]) for comp, fmu in components.items()},
            name=name,
        )
        lines.append(f"wrote {path} (Road -> Car <-> Body, Car <-> Controller, 1 ms step)")
        interrupts.check()
    for line in lines:
        progress_lines(progress)(line)
    return path
