"""Build ``SkyhookController.fmu``: the skyhook/groundhook law as a native FMI 2.0 FMU.

A stateless co-simulation FMU in C (``fmu_src/native/bodyvib_skyhook.c``, no Python on
the host): per actuator it reads the absolute vertical velocities (and accelerations) of
the actuator's upper and lower points and gives the force

    actuator_force = -c_sky * vu + c_ground * vl                               [N]

(positive pushing the points apart) and its rate ``actuator_force_rate`` (the same law
on the accelerations), set to 0 by the ``semi_active`` parameter where a passive damper
could not give it. ``vu`` and ``vl`` are the velocities in force: the velocity inputs as
the host set them last, carried over each communication step along the acceleration
inputs. A Jacobi host (libcosim, fmpy's SSP runner) sets the car's velocities of the
previous communication point and reads after the step: the carried velocities make the
force it reads the one of the current point (to second order in ``h``). A host that sets
the current velocities and then reads (OMSimulator) gets the law of the values it set:
the outputs follow new inputs at once. The outputs are feedthrough, computed on read.
The FMI state machine, its messages and the step's checks are those of every native
bodyvib FMU (``bodyvib_fsm.c``); a call out of order, a step not from the model's time,
a non-finite value or a force that would overflow is refused with ``fmi2Error`` and one
log line, nothing changed. Variable names
follow the car FMU's actuators: for the suffix ``_front`` the inputs are
``upper_velocity_front``, ``lower_velocity_front``, ``upper_acceleration_front``,
``lower_acceleration_front`` (from the car's ``actuator_upper_velocity_front`` ...) and
the outputs ``actuator_force_front`` and ``actuator_force_rate_front`` (to the car's
inputs of the same names).

The FMU ships ``sources/`` (the C files and the generated configuration header) and
``binaries/linux64`` (and ``win64`` when mingw-w64 is installed); its model description
is written by :func:`bodyvib.fmu.description.write_model_description` and the FMU built by
:func:`bodyvib.fmu.native.package_c_fmu`, as every native FMU, and checked with
``fmpy validate`` before it is written.
"""

import math
import os
from pathlib import Path
from typing import Iterable, List, Optional, Sequence, Tuple

from .. import __version__
from ..runtime.contract import Variable
from ..runtime.errors import BodyvibError
from .description import InterfaceElement, ModelDescription, write_model_description
from .native import LOG_CATEGORIES, choose_platforms, package_c_fmu

__all__ = ["CONTROLLER_NAME", "CONTROLLER_SOURCE", "controller_variables", "build_controller_fmu"]

#: Model name and identifier of the controller FMU.
CONTROLLER_NAME = "SkyhookController"
#: Its C source in ``fmu_src/native``.
CONTROLLER_SOURCE = "bodyvib_skyhook.c"
_CONFIG = "bodyvib_skyhook_config.h"
#: What it ships in ``sources/`` and compiles: the FMI state machine every native FMU shares.
_SOURCES = (
    "bodyvib_core.h",
    "bodyvib_fsm.h",
    "bodyvib_fsm.c",
    "bodyvib_calls.h",
    CONTROLLER_SOURCE,
)
_C_FILES = ("bodyvib_fsm.c", CONTROLLER_SOURCE)


def controller_variables(suffixes: Sequence[str]) -> List[Tuple[str, str, str]]:
    """The controller FMU's Real variables by value reference: (name, causality, unit).

    Parameters
    ----------
    suffixes : sequence of str
        The car's actuator suffixes (``""`` for one unnamed actuator, ``"_front"``, ...).

    Returns
    -------
    list of (str, str, str)
        Inputs (two per actuator), outputs (one per actuator), then ``c_sky`` and
        ``c_ground``.

    Examples
    --------
    >>> [v[0] for v in controller_variables([""])][:6]
    ['upper_velocity', 'lower_velocity', 'upper_acceleration', 'lower_acceleration', 'actuator_force', 'actuator_force_rate']
    """
    out = []
    for s in suffixes:
        out += [(f"upper_velocity{s}", "input", "m/s"), (f"lower_velocity{s}", "input", "m/s")]
        out += [(f"upper_acceleration{s}", "input", "m/s2")]
        out += [(f"lower_acceleration{s}", "input", "m/s2")]
    out += [(f"actuator_force{s}", "output", "N") for s in suffixes]
    out += [(f"actuator_force_rate{s}", "output", "N/s") for s in suffixes]
    return out + [("c_sky", "parameter", "N.s/m"), ("c_ground", "parameter", "N.s/m")]


def _variables(suffixes: Sequence[str], c_sky: float, c_ground: float) -> Tuple[Variable, ...]:
    """The controller's real variables as the model description writer takes them."""
    starts = {"c_sky": c_sky, "c_ground": c_ground}
    out = []
    for name, causality, unit in controller_variables(suffixes):
        if causality == "parameter":
            text = f"{'Skyhook' if name == 'c_sky' else 'Groundhook'} gain"
            out.append(Variable(name, causality, "fixed", unit, text, float(starts[name]), 0.0))
        elif causality == "input":
            which, quantity = name.split("_")[:2]
            text = f"Absolute vertical {quantity} of the actuator's {which} point"
            out.append(Variable(name, causality, "continuous", unit, text, 0.0))
        else:
            text = (
                "Time derivative of the actuator force (the law on the accelerations)"
                if "_rate" in name
                else "Actuator force, positive pushing the two points apart"
            )
            out.append(Variable(name, causality, "continuous", unit, text))
    return tuple(out)


def _description(
    suffixes: Sequence[str], c_sky: float, c_ground: float, semi: bool, token: str
) -> bytes:
    """``modelDescription.xml``, by the one writer of every bodyvib FMU."""
    n = len(suffixes)
    # per output: the inputs it depends on (value references): the force on its actuator's
    # four inputs, the rate on its two accelerations
    deps = tuple(tuple(range(4 * i, 4 * i + 4)) for i in range(n))
    deps += tuple((4 * i + 2, 4 * i + 3) for i in range(n))
    cs = InterfaceElement(
        "CoSimulation",
        (
            ("needsExecutionTool", "false"),
            ("canHandleVariableCommunicationStepSize", "true"),
            ("canInterpolateInputs", "false"),
            ("maxOutputDerivativeOrder", "0"),
            ("canBeInstantiatedOnlyOncePerProcess", "false"),
            ("canNotUseMemoryManagementFunctions", "true"),
            ("canGetAndSetFMUstate", "false"),
            ("canSerializeFMUstate", "false"),
            ("providesDirectionalDerivative", "false"),
        ),
        _C_FILES,
    )
    semi_text = "Semi-active (on-off) clipping: 0 where a passive damper cannot give the force"
    return write_model_description(
        ModelDescription(
            fmi=2,
            model_name=CONTROLLER_NAME,
            model_identifier=CONTROLLER_NAME,
            token=token,
            description="Skyhook/groundhook actuator force law (stateless feedthrough): "
            "actuator_force = -c_sky upper_velocity + c_ground lower_velocity",
            generation_tool=f"bodyvib {__version__}",
            variables=_variables(suffixes, c_sky, c_ground),
            output_dependencies=deps,
            interfaces=(cs,),
            log_categories=LOG_CATEGORIES,
            stop_time=10.0,
            booleans=(("semi_active", semi_text, bool(semi)),),
        )
    )


def _config(suffixes: Sequence[str], c_sky: float, c_ground: float, semi: bool, token: str) -> str:
    kinds = {"input": 0, "output": 1, "parameter": 2}  # BV_INPUT .. BV_PARAMETER
    variables = controller_variables(suffixes)
    return "\n".join(
        [
            f"/* Generated by bodyvib {__version__} (bodyvib.fmu.controller): do not edit. */",
            f"#define BV_ACTUATORS {len(suffixes)}",
            f'#define BV_TOKEN "{token}"',
            "#define BV_VR_KINDS " + ", ".join(str(kinds[c]) for _, c, _ in variables),
            "#define BV_VR_NAMES " + ", ".join(f'"{name}"' for name, _, _ in variables),
            f"#define BV_C_SKY {float(c_sky)!r}",
            f"#define BV_C_GROUND {float(c_ground)!r}",
            f"#define BV_SEMI_ACTIVE {1 if semi else 0}",
            "",
        ]
    )


def build_controller_fmu(
    dest: "str | os.PathLike[str]",
    suffixes: Sequence[str] = ("",),
    c_sky: float = 0.0,
    c_ground: float = 0.0,
    semi_active: bool = False,
    platforms: Optional[Iterable[str]] = None,
) -> Path:
    """Build ``SkyhookController.fmu`` (FMI 2.0 co-simulation, native C).

    Parameters
    ----------
    dest : str or path
        Output folder.
    suffixes : sequence of str
        One per actuator of the car it drives: ``("",)`` for the quarter car,
        ``("_front", "_rear")`` for the half car.
    c_sky, c_ground : float
        Start values of the gains, N s/m (parameters of the FMU, tunable before
        initialization).
    semi_active : bool
        Start value of the ``semi_active`` parameter.
    platforms : iterable of str, optional
        Keys of :data:`bodyvib.fmu.native.PLATFORMS` (default: every one with a compiler).

    Returns
    -------
    Path
        ``dest/SkyhookController.fmu``.

    Raises
    ------
    BodyvibError
        A gain that is not a finite number >= 0, no actuator, a missing compiler, a
        compiler error, or fmpy validate finding a problem.
    """
    for name, value in (("c_sky", c_sky), ("c_ground", c_ground)):
        if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise BodyvibError(f"controller gain {name} = {value!r} must be a finite number >= 0")
    suffixes = tuple(suffixes)
    if not suffixes or len(set(suffixes)) != len(suffixes):
        raise BodyvibError("the controller FMU needs one distinct suffix per actuator")
    chosen = choose_platforms(platforms).platforms
    return package_c_fmu(
        CONTROLLER_NAME,
        2,
        _SOURCES,
        lambda token: {_CONFIG: _config(suffixes, c_sky, c_ground, semi_active, token)},
        _C_FILES,
        lambda token: _description(suffixes, c_sky, c_ground, semi_active, token),
        {},
        dest,
        chosen,
        f"{CONTROLLER_NAME}.fmu",
    )
