"""Run the shipped SSP (road, quarter car, occupant) with fmpy's SSP runner, unchanged.

Build it first (``python build_fmu.py``), then::

    python examples/ssp_from_fmpy.py [dist/QuarterCarWithOccupant.ssp] [DURATION]

What fmpy's runner (``fmpy.ssp.simulation.simulate_ssp``, fmpy 0.3) handles, and
what a user must therefore give it:

* the step: ``step_size`` (its default is 1 % of the stop time: 0.3 s on 30 s);
  the SSP's default experiment and step annotation are not read;
* the parameter set: it reads no ParameterBinding of the SSD; this script turns
  the SSP's bindings (one ``.ssv`` per component) into the ``parameter_set``
  argument, names prefixed with the component (``Road.speed``), so an edited
  ``.ssv`` takes effect;
* times: each row holds the values after the step that *starts* at its
  ``time``; this script shifts them to the step's end;
* the start: every connection starts at 0 and outputs are first exchanged after
  the first step (the car drives its first step on a flat road), which the
  road's own value at t = 0 makes a small, measured error (docs/tutorials/fmu_hosts.md,
  "Co-simulation in any host (SSP)").

tests/test_ssp.py runs this function.
"""

import numpy as np
from _ssp_host import DEFAULT_SSP, main

__all__ = ["parameter_set", "run"]


def parameter_set(ssp_path):
    """The SSP's per-component parameter bindings as one fmpy ``ParameterSet``.

    Parameters
    ----------
    ssp_path : str
        The ``.ssp`` file, whose SSD binds one ``.ssv`` to each component.

    Returns
    -------
    fmpy.ssp.ssd.ParameterSet
        Parameter names ``<component>.<variable>``, as ``simulate_ssp`` expects.
    """
    from fmpy.ssp.ssd import Parameter, ParameterSet, read_ssd

    out = ParameterSet(name="bindings")
    for comp in read_ssd(str(ssp_path)).system.elements:
        for binding in getattr(comp, "parameterBindings", []):
            prefix = binding.prefix or ""
            for values in binding.parameterValues:
                for p in values.parameters:
                    name = p.name[len(prefix) :] if prefix and p.name.startswith(prefix) else p.name
                    out.parameters.append(
                        Parameter(
                            name=f"{comp.name}.{name}", type=p.type, value=p.value, unit=p.unit
                        )
                    )
    return out


def run(ssp_path=DEFAULT_SSP, duration=30.0, step=1e-3):
    """Simulate the SSP with ``fmpy.ssp.simulation.simulate_ssp``.

    Parameters
    ----------
    ssp_path : str
        The ``.ssp`` file; :func:`parameter_set` reads its bindings.
    duration : float
        Simulated time, s (``stop_time`` half a step short of it, so that fmpy takes the
        last step exactly once).
    step : float
        Communication step, s: ``simulate_ssp``'s ``step_size`` (its default, 1 % of the
        stop time, is far too coarse).

    Returns
    -------
    dict of str to ndarray
        ``time`` [s] (``0, h, 2h, ...``) and every connector, ``"<component>.<variable>"``,
        at those times (row 0: the system at rest, as the FMUs start).
    """
    from fmpy.ssp.simulation import simulate_ssp

    res = simulate_ssp(
        str(ssp_path),
        stop_time=duration - step / 2,
        step_size=step,
        parameter_set=parameter_set(ssp_path),
    )
    n = res.size
    out = {"time": np.arange(n + 1) * step}
    for name in res.dtype.names[1:]:
        out[name] = np.concatenate([[0.0], res[name]])  # row k: after the step from t_k
    return out


if __name__ == "__main__":
    main(run)
