"""``bodyvib control``: the passive car against skyhook and groundhook control on one road.

Each law runs as the seated car's exact closed loop (no FMUs, no coupling error; a car
whose tires are contacts with stops on its suspensions stepped with located events,
``--linear`` linearized); the
table gives head Wk r.m.s., tire-force r.m.s., suspension-travel r.m.s. and actuator
force r.m.s. per law. ``bodyvib cosim --control LAW`` co-simulates one law with FMUs.
"""

from bodyvib.process.outputs import write_json
from bodyvib.runtime.errors import BodyvibError

from .flags import in_flags
from .options import (
    add_output_options,
    add_road_options,
    add_run_options,
    run_settings_from_args,
)
from .outputs import check_files, write_outputs

__all__ = ["add_command"]


def _run(args):
    from bodyvib.models import load_model
    from bodyvib.vehicle.active import compare_laws, format_comparison, plot_laws
    from bodyvib.vehicle.quarter_car import load_car
    from bodyvib.vehicle.study import check_settings

    check_files(args, ("json", "plot"))
    settings = run_settings_from_args(args)
    check_settings(settings)
    car, body = load_car(args.car), load_model(args.params)
    laws = [s.strip() for s in args.laws.split(";") if s.strip()]
    if not laws:
        raise BodyvibError("--laws is empty; give e.g. 'passive;skyhook;groundhook'")
    comparison = compare_laws(car, body, settings, laws, linear=args.linear)
    print(in_flags(format_comparison(comparison), ("linear",)))
    write_outputs(
        [
            (args.json, lambda path: write_json(path, _json(comparison))),
            (args.plot, lambda path: plot_laws(comparison, path)),
        ]
    )
    return 0


def _json(comparison):
    """The figures as JSON-ready data."""
    from bodyvib.vehicle.active import lift_offs

    return {
        "car": comparison.car,
        "body": comparison.body,
        "linear": comparison.linear,
        "settings": comparison.settings.to_dict(),
        "laws": [
            {
                "law": f.law,
                "c_sky_N_s_m": f.controller.c_sky if f.controller else 0.0,
                "c_ground_N_s_m": f.controller.c_ground if f.controller else 0.0,
                "head_wk_rms_m_s2": f.head_wk_rms,
                "tire_force_rms_N": f.tire_force_rms,
                "suspension_travel_rms_m": f.suspension_travel_rms,
                "actuator_force_rms_N": f.actuator_force_rms,
                "lift_offs": lift_offs(f)[0],
                "stop_contacts": lift_offs(f)[1],
                "events": f.events,
                "warnings": list(f.warnings),
            }
            for f in comparison.laws
        ],
    }


def add_command(subparsers):
    """Register ``bodyvib control``."""
    p = subparsers.add_parser(
        "control",
        help="passive against skyhook and groundhook control: comfort and road holding",
        description="Drive a car with actuators (quarter-car-active, half-car-active, "
        "full-car-active) with "
        "the occupant over a road under each control law, as the exact closed loop; print "
        "head Wk r.m.s., tire-force r.m.s., suspension-travel r.m.s. and actuator-force "
        "r.m.s. per law (and, unless --linear, each law's lift-offs and stop contacts).",
    )
    p.add_argument(
        "--car",
        default="quarter-car-active",
        metavar="MODEL",
        help="car with actuators: shipped name or parameter file (default quarter-car-active)",
    )
    p.add_argument(
        "--params",
        default="reduced-paper",
        metavar="MODEL",
        help="occupant: shipped body model or parameter file (default reduced-paper)",
    )
    p.add_argument(
        "--laws",
        default="passive;skyhook;groundhook",
        help="laws separated by ';': passive, or skyhook/groundhook/hybrid with options "
        "as for cosim --control (c=<N s/m>, g=<N s/m>), e.g. 'passive;skyhook:c=3000' "
        "(default: %(default)s)",
    )
    p.add_argument(
        "--road",
        default="C",
        help="ISO 8608 class A-H, 'bump', 'sweep', a bump shape or a road file (default C)",
    )
    add_road_options(p)
    add_run_options(p, step="time step")
    p.add_argument(
        "--linear",
        action="store_true",
        help="run the car linearized about static equilibrium: its tires never leave the "
        "road and its suspensions have no stops (the linear active car of earlier releases)",
    )
    add_output_options(
        p,
        plot="write the time traces of the laws side by side",
        json="write the figures as JSON",
    )
    p.set_defaults(func=_run)
    return p
