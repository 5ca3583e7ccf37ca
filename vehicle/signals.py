"""The signals of a run: one table of name, unit, meaning and where each comes from.

A co-simulation (:func:`bodyvib.vehicle.cosim.cosimulate`, :class:`bodyvib.vehicle.cosim.Master`) and the
monolithic reference (:func:`bodyvib.vehicle.reference.reference_run`,
:class:`bodyvib.vehicle.reference.ReferenceStream`) give the same signals; the CSV header
(``name [unit]``), the study's CSV columns and the plot's axis labels read them here.
The order of :data:`SIGNALS` is the order of a run's columns (result dicts and CSV).

Each signal says where it comes from:

- ``"grid"``, ``"road"``: the time grid and the road input (the master's input);
- ``"car"``: an output of the car FMU (:attr:`Signal.variable`), recorded at ``t_k``
  after the car's inputs of ``t_k`` are set;
- ``"body"``: an output of the body FMU (:attr:`Signal.variable`).

In the reference each car and body signal is an output of the seated system
(:attr:`Signal.seated`, ``{seat}`` standing for the car's seat point); the seat force has
none: it is the occupant's own output moved onto the seated system
(:func:`bodyvib.vehicle.reference.seat_force_weights`).
"""

from dataclasses import dataclass
from typing import Dict, Literal, Optional, Tuple

__all__ = [
    "Signal",
    "SIGNALS",
    "UNITS",
    "MASTER_SIGNALS",
    "CAR_SIGNALS",
    "BODY_SIGNALS",
    "OPTIONAL_SIGNALS",
    "CAR_DEFAULTS",
    "OPTIONAL_CAR_SIGNALS",
    "header",
    "axis_label",
    "car_variable",
    "corner_variable",
    "WHEELS",
    "WHEEL_SIGNALS",
    "car_wheels",
    "wheel_columns",
]


@dataclass(frozen=True)
class Signal:
    """One signal of a run.

    Attributes
    ----------
    name : str
        Column name (result dicts, CSV).
    unit : str
        SI unit as written in CSV headers and plot labels.
    meaning : str
        What it is, with its sign convention.
    source : str
        ``"grid"``, ``"road"``, ``"car"`` or ``"body"`` (module docstring).
    variable : str or None
        The FMU output the master reads (car and body signals).
    seated : str or None
        The output of the seated system the reference reads (``{seat}``: the car's seat
        point); None for the seat force and for grid and road.
    """

    name: str
    unit: str
    meaning: str
    source: Literal["grid", "road", "car", "body"]
    variable: Optional[str] = None
    seated: Optional[str] = None

    def seated_output(self, seat: str) -> Optional[str]:
        """The seated system's output of this signal for a car whose seat point is ``seat``."""
        return None if self.seated is None else self.seated.format(seat=seat)


#: Every signal of a run, in column order.
SIGNALS: Tuple[Signal, ...] = (
    Signal("time", "s", "communication point t_k = k h", "grid"),
    Signal("road_displacement", "m", "road profile under the (front) tire", "road"),
    Signal("road_velocity", "m/s", "slope of the road profile in time", "road"),
    Signal(
        "seat_displacement", "m", "the car's seat point", "car", "seat_displacement", "{seat}.x"
    ),
    Signal("seat_velocity", "m/s", "the car's seat point", "car", "seat_velocity", "{seat}.v"),
    Signal(
        "seat_acceleration",
        "m/s2",
        "the car's seat point, absolute",
        "car",
        "sprung_acceleration",
        "{seat}.a",
    ),
    Signal(
        "suspension_deflection",
        "m",
        "+ in extension (a half car's: the front axle's; a full car's: the front left)",
        "car",
        "suspension_deflection",
        "suspension.deflection",
    ),
    Signal(
        "tire_force",
        "N",
        "+ in compression (a half car's: the front axle's; a full car's: the front left)",
        "car",
        "tire_force",
        "tire.force",
    ),
    Signal(
        "tire_contact",
        "1",
        "1 while the (front) tire touches the road, 0 in the air (a linear car: always 1)",
        "car",
        "tire_contact",
        "tire.contact",
    ),
    Signal(
        "stop_force",
        "N",
        "force of the (front) suspension's stops, + bump, - rebound (0 without stops)",
        "car",
        "stop_force",
        "stops.force",
    ),
    Signal(
        "seat_acceleration_x",
        "m/s2",
        "the car's seat point, forward, from the body's pitch: -h theta'' (h: the seat's "
        "height above the centre of mass; inertial, gravity not included; NaN: a car "
        "without it)",
        "car",
        "seat_acceleration_x",
        "{seat}.ax",
    ),
    Signal(
        "seat_acceleration_y",
        "m/s2",
        "the car's seat point, to the left, from the body's roll: -h phi'' (roll positive "
        "left side up; inertial, gravity not included; NaN: a car without it)",
        "car",
        "seat_acceleration_y",
        "{seat}.ay",
    ),
    Signal(
        "seat_force",
        "N",
        "force of the occupant on the seat, + in compression",
        "body",
        "seat_force",
    ),
    Signal(
        "head_acceleration",
        "m/s2",
        "the occupant's head, absolute",
        "body",
        "head_acceleration",
        "body.head.a",
    ),
    Signal(
        "head_displacement", "m", "the occupant's head", "body", "head_displacement", "body.head.x"
    ),
    Signal(
        "torso_displacement",
        "m",
        "the occupant's torso",
        "body",
        "torso_displacement",
        "body.torso.x",
    ),
    Signal(
        "neck_force",
        "N",
        "force in the occupant's neck element, + in compression (NaN: the model names none)",
        "body",
        "neck_force",
        "body.neck_force",
    ),
    Signal(
        "lumbar_force",
        "N",
        "force in the occupant's lumbar element, + in compression (NaN: the model names none)",
        "body",
        "lumbar_force",
        "body.lumbar_force",
    ),
)

#: Body signals a body model may lack (a model file without named ``forces``, a foreign
#: FMU): a run records them as NaN.
OPTIONAL_SIGNALS: Tuple[str, ...] = ("neck_force", "lumbar_force")

#: Car signals a car model may lack (a linear car has no contact and no stops), and the
#: value a run records for them then.
CAR_DEFAULTS: Dict[str, float] = {"tire_contact": 1.0, "stop_force": 0.0}
#: Car signals a car may lack (all but a full car: a car whose body does not roll has
#: no seat height): a run records them as NaN. They follow the car's other signals.
OPTIONAL_CAR_SIGNALS: Tuple[str, ...] = ("seat_acceleration_x", "seat_acceleration_y")

#: The wheels of a car with several, named as its FMU variables' suffixes: a half car's
#: axles, a full car's corners.
WHEELS: Tuple[str, ...] = ("front", "rear", "front_left", "front_right", "rear_left", "rear_right")

#: The signals a car with several wheels gives per wheel, each as the column (and the car
#: FMU output) ``<signal>_<wheel>``: ``tire_contact_front``, ``stop_force_rear_left``.
#: The table's own ``tire_contact``, ``stop_force`` and ``tire_force`` are the front (left)
#: wheel's there; a quarter car has no per-wheel columns.
WHEEL_SIGNALS: Tuple[str, ...] = ("tire_contact", "stop_force", "tire_force")

#: Unit of each signal by name (the per-wheel columns too).
UNITS: Dict[str, str] = {s.name: s.unit for s in SIGNALS}
UNITS.update({f"{name}_{w}": UNITS[name] for name in WHEEL_SIGNALS for w in WHEELS})

#: The car's signals, in column order.
CAR_SIGNALS: Tuple[Signal, ...] = tuple(s for s in SIGNALS if s.source == "car")

#: The body's signals, in column order.
BODY_SIGNALS: Tuple[Signal, ...] = tuple(s for s in SIGNALS if s.source == "body")

#: Names of the signals the master records (car, then body): the columns of
#: :meth:`bodyvib.vehicle.cosim.Master.advance`.
MASTER_SIGNALS: Tuple[str, ...] = tuple(s.name for s in CAR_SIGNALS + BODY_SIGNALS)


def car_variable(signal: Signal, variables) -> str:
    """The car FMU variable a car signal reads: its own, or on a car with axles the front one's.

    A half car has no ``suspension_deflection``; it has ``suspension_deflection_front``
    and ``suspension_deflection_rear``. The signal table's per-car columns are the
    front axle's there, and a full car's front left corner's
    (``suspension_deflection_front_left``).

    Parameters
    ----------
    signal : Signal
        A signal of the table.
    variables : collection of str
        The car FMU's variable names (or its parameter file's ``fmu_outputs`` names).

    Returns
    -------
    str
        ``signal.variable`` if the car has it, else ``signal.variable + "_front"`` or
        ``+ "_front_left"`` if it has that, else ``signal.variable``.

    Examples
    --------
    >>> tire = SIGNALS[7]  # tire_force
    >>> car_variable(tire, {"tire_force"}), car_variable(tire, {"tire_force_front"})
    ('tire_force', 'tire_force_front')
    """
    return (
        signal.variable if signal.variable is None else corner_variable(signal.variable, variables)
    )


def corner_variable(name: str, variables) -> str:
    """``name``, or on a car with axles the front axle's (``_front``) or a full car's
    front left corner's (``_front_left``) variable of that name, if the car has it.

    Examples
    --------
    >>> corner_variable("tire_force", {"tire_force_front_left"})
    'tire_force_front_left'
    """
    if name not in variables:
        for corner in ("_front", "_front_left"):  # a half car's front axle, a full car's
            if name + corner in variables:
                return name + corner
    return name


def header(column: str) -> str:
    """CSV header of a column: ``name [unit]``.

    A column named after a signal, possibly prefixed (``<label>.`` for a body of a study,
    ``reference_`` for the reference's), has that signal's unit; another has no unit.

    Parameters
    ----------
    column : str
        A column of a run's table, e.g. ``head_acceleration`` or
        ``HumanBody3DOF.reference_head_acceleration``.

    Returns
    -------
    str
        ``column [unit]``, or ``column`` alone when no signal gives it a unit.

    Examples
    --------
    >>> header("HumanBody3DOF.reference_head_acceleration")
    'HumanBody3DOF.reference_head_acceleration [m/s2]'
    >>> header("gain")
    'gain'
    """
    unit = UNITS.get(column.rpartition(".")[2].replace("reference_", ""))
    return f"{column} [{unit}]" if unit else column


def axis_label(name: str) -> str:
    """Plot axis label of a signal: words and unit, ``head acceleration [m/s2]``.

    Parameters
    ----------
    name : str
        A signal's name (a key of :data:`UNITS`).

    Returns
    -------
    str
        The name with spaces for underscores, then its unit in brackets.

    Examples
    --------
    >>> axis_label("head_acceleration")
    'head acceleration [m/s2]'
    """
    return f"{name.replace('_', ' ')} [{UNITS[name]}]"


def car_wheels(variables) -> Tuple[str, ...]:
    """The wheels (:data:`WHEELS`) of a car with several whose tires are contacts.

    Parameters
    ----------
    variables : collection of str
        The car FMU's variable names (or its parameter file's ``fmu_outputs`` names).

    Returns
    -------
    tuple of str
        Each wheel whose every :data:`WHEEL_SIGNALS` output the car has, in the order of
        :data:`WHEELS`; ``()`` for a quarter car or a linear car (no contact flags).

    Examples
    --------
    >>> names = {f"{s}_{w}" for s in WHEEL_SIGNALS for w in ("front", "rear")}
    >>> car_wheels(names), car_wheels({"tire_contact", "stop_force", "tire_force"})
    (('front', 'rear'), ())
    """
    return tuple(w for w in WHEELS if all(f"{s}_{w}" in variables for s in WHEEL_SIGNALS))


def wheel_columns(wheels) -> Tuple[str, ...]:
    """The per-wheel columns of a run, wheel by wheel: ``<signal>_<wheel>``.

    Parameters
    ----------
    wheels : sequence of str
        :func:`car_wheels` of the car.

    Returns
    -------
    tuple of str
        For each wheel its :data:`WHEEL_SIGNALS` columns.

    Examples
    --------
    >>> wheel_columns(("rear",))
    ('tire_contact_rear', 'stop_force_rear', 'tire_force_rear')
    """
    return tuple(f"{s}_{w}" for w in wheels for s in WHEEL_SIGNALS)
