"""``bodyvib fit``: refit the reduced model by a genetic algorithm and write a parameter file."""

import os

from bodyvib.fit.config import load_config, parse_pairs
from bodyvib.fit.methods import METHODS
from bodyvib.fit.objective import measured_target, model_target
from bodyvib.fit.result import write_parameter_file
from bodyvib.fit.search import fit
from bodyvib.process import extras, interrupts
from bodyvib.process.outputs import check_outputs, staged_writes
from bodyvib.runtime.errors import BodyvibError

from .outputs import JSON_EXTENSIONS, PLOT_EXTENSIONS

#: Files ``--report DIR`` writes (bodyvib.fit.report.write_report).
REPORT_FILES = (
    ("comparison.md", None),
    ("comparison.json", JSON_EXTENSIONS),
    ("transmissibility.png", PLOT_EXTENSIONS),
    ("impulse_response.png", PLOT_EXTENSIONS),
)

__all__ = ["add_command"]


def _command_line(args) -> str:
    parts = ["bodyvib fit"]
    if args.measured:
        parts += ["--measured", args.measured]
        if args.total_mass is not None:
            parts += ["--total-mass", f"{args.total_mass:g}"]
    else:
        parts += ["--reference", args.reference]
    parts += ["--seed", str(args.seed), "--out", args.out]
    if args.config:
        parts += ["--config", args.config]
    if args.pairs:
        parts += ["--pairs", args.pairs]
    if args.method is not None:
        parts += ["--method", args.method]
    if args.polish is not None:
        parts += ["--polish" if args.polish else "--no-polish"]
    if args.pareto:
        parts += ["--pareto", "--report", args.report]
    return " ".join(parts)


def _check_files(args):
    inputs = [
        ("--reference", args.reference if not args.measured else None),
        ("--measured", args.measured),
        ("--config", args.config),
    ]
    inputs = [(o, p) for o, p in inputs if p is not None and os.path.isfile(p)]
    outputs = [("--out", args.out, JSON_EXTENSIONS)]
    if args.report:
        outputs.append(("--report", args.report, None, True))
        outputs += [
            (f"--report {name}", os.path.join(args.report, name), ext) for name, ext in REPORT_FILES
        ]
    check_outputs(outputs, inputs)


def _run(args):
    extras.require("bodyvib fit", "fit")
    if args.pareto and not args.report:
        raise BodyvibError("--pareto writes its front into --report DIR: give --report")
    if args.pareto and args.measured:
        raise BodyvibError(
            "--pareto needs a reference model (the peak error is against its "
            "transmissibility), not --measured data"
        )
    _check_files(args)
    cfg = load_config(args.config)
    if args.measured:
        if args.pairs:
            raise BodyvibError(
                "--pairs applies to a reference model; measured data are seat-to-head only"
            )
        target = measured_target(args.measured, args.total_mass)
    else:
        if args.total_mass is not None:
            raise BodyvibError(
                "--total-mass applies to --measured data; with a reference "
                "model the total mass is its static apparent mass"
            )
        pairs = parse_pairs(args.pairs) if args.pairs else None
        target = model_target(args.reference, pairs, cfg)
    log = (lambda *a: None) if args.quiet else print
    log(
        f"fitting the reduced model to {target.description}; total mass pinned to "
        f"{target.total_mass:g} kg; seed {args.seed}"
    )
    result = fit(
        target, cfg, seed=args.seed, polish=args.polish, progress=not args.quiet, method=args.method
    )
    front = None
    if args.pareto:  # searched before anything is written: all outputs or none
        from bodyvib.fit.pareto import pareto_front
        from bodyvib.fit.space import REDUCED_PARAMETERS

        start = [result.parameters[k] for k in REDUCED_PARAMETERS]
        front = pareto_front(target, cfg, seed=args.seed, start=start, progress=not args.quiet)
    with staged_writes(guard=interrupts.critical) as written:  # parameter file, report, front
        net = write_parameter_file(result, args.out, command=_command_line(args))
        if args.report:
            from bodyvib.fit.report import write_report

            write_report(args.report, result, net)
        if front is not None:
            from bodyvib.fit.pareto import write_pareto

            write_pareto(args.report, front, command=_command_line(args))
        interrupts.check()  # Ctrl-C while rendering: discard, keep the old files
    log(
        f"objective J: Table 2 {result.objective_table2:.6g} 1/s, refit "
        f"{result.objective:.6g} 1/s ({result.objective / result.objective_table2:.1%} of "
        f"Table 2; {result.method} {result.ga_objective:.6g} before polish), {result.evaluations} "
        f"evaluations in {result.elapsed_s:.1f} s"
    )
    log("parameters: " + ", ".join(f"{k} {v:.5g}" for k, v in result.parameters.items()))
    if result.at_bounds:
        log("at a bound of the search: " + "; ".join(result.at_bounds))
    if front is not None:
        from bodyvib.fit.pareto import chosen_points

        ref = front.reference_peak
        log(
            f"Pareto front (NSGA-II, {front.evaluations} evaluations in {front.elapsed_s:.1f} s): "
            f"{len(front.objective)} points; reference |T| peak {ref[0]:.3f} at {ref[1]:.2f} Hz"
        )
        for name, i in chosen_points(front).items():
            m, f = front.peak[i]
            log(
                f"  {name:<15} J {front.objective[i]:.4g} 1/s, peak error "
                f"{front.peak_error[i]:.3g}: |T| peak {m:.3f} at {f:.2f} Hz"
            )
    log("wrote " + ", ".join(written.paths))
    return 0


def add_command(subparsers):
    """Register ``bodyvib fit``."""
    p = subparsers.add_parser(
        "fit",
        help="refit the reduced model by a genetic algorithm (paper Eq. 3)",
        description="Refit the reduced 3-DOF model's parameters by a genetic algorithm "
        "(default; CMA-ES or differential evolution with --method) to the head and torso "
        "impulse responses of a reference model (the paper's "
        "Eq. 3; --pairs chooses) or to "
        "a measured seat-to-head transmissibility, and write a parameter file with its "
        "provenance that build_fmu.py --params bakes into the FMU.",
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument(
        "--reference",
        default="iso7962",
        metavar="MODEL",
        help="reference model: shipped name or parameter file (default iso7962)",
    )
    src.add_argument(
        "--measured",
        metavar="FILE.csv",
        help="measured transmissibility: CSV with header frequency_hz,modulus[,phase_deg]",
    )
    p.add_argument(
        "--total-mass",
        type=float,
        metavar="KG",
        help="with --measured: total mass m1 + m2 to pin, kg (default 75)",
    )
    p.add_argument("--seed", type=int, default=1, help="search seed (default 1)")
    p.add_argument(
        "--method",
        choices=METHODS,
        help="search: ga (genetic algorithm), cmaes or de (comparators); default "
        "per the configuration, ga",
    )
    p.add_argument(
        "--out",
        default="params/refit.json",
        metavar="FILE.json",
        help="parameter file to write (default params/refit.json)",
    )
    p.add_argument(
        "--config",
        metavar="FILE.json",
        help="settings overriding bodyvib/data/fit/default-config.json",
    )
    p.add_argument(
        "--pairs",
        metavar="ROLE=W,...",
        help="position pairs and weights, e.g. head=1,torso=0.5 (default "
        "head=1,torso=1, from the configuration)",
    )
    p.add_argument(
        "--report",
        metavar="DIR",
        help="write a comparison with the paper's Table 2 (table, JSON, plots)",
    )
    p.add_argument(
        "--polish",
        dest="polish",
        action="store_true",
        default=None,
        help="local polish after the GA (default: per the configuration, on)",
    )
    p.add_argument("--no-polish", dest="polish", action="store_false", help="skip the local polish")
    p.add_argument(
        "--pareto",
        action="store_true",
        help="also draw the trade-off of J against the transmissibility peak error "
        "(NSGA-II) into --report DIR: table, plot, parameter files",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar and no messages")
    p.set_defaults(func=_run)
    return p
