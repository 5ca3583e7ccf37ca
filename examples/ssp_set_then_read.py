"""Run a shipped SSP in a master that sets inputs and then reads outputs (OMSimulator's order).

Build it first (``python build_fmu.py``), then::

    python examples/ssp_set_then_read.py [dist/QuarterCarWithOccupant.ssp] [DURATION]

The three other SSP hosts of this folder (libcosim, Ecos, fmpy's runner) are Jacobi
masters: at a communication point they read every output, then set every input, so an
output that depends on an input directly (a feedthrough output: the controller's force,
the body's seat force) is read before the input it depends on is set. OpenModelica's
OMSimulator sorts the connections by the FMUs' declared dependencies and sets an FMU's
inputs before it reads the outputs that depend on them. This master does the same from
plain fmpy calls: after every FMU has stepped to the next communication point it sweeps
the SSP's connections in order -- read the start connector, set the end connector -- and
repeats the sweep until no input changes (the algebraic loop through the car's and the
body's feedthrough converges in a few sweeps), so every output it records and passes on
is that of the inputs in force at that point. Parameters come from the SSP's bindings
(:func:`ssp_from_fmpy.parameter_set`); FMI 2.0 and 3.0 packages both run.

tests/test_set_then_read.py runs every shipped SSP through it.
"""

import os
import shutil
import tempfile
import zipfile

import numpy as np
from _ssp_host import DEFAULT_SSP, main
from ssp_from_fmpy import parameter_set

__all__ = ["MAX_SWEEPS", "run"]

#: Sweeps over the connections at one communication point before the values must agree.
MAX_SWEEPS = 50


class _Component:
    """One FMU of the SSP, instantiated in fmpy and initialized with its bindings."""

    def __init__(self, name, fmu_path, bindings, folder):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave
        from fmpy.fmi3 import FMU3Slave

        md = read_model_description(fmu_path)
        self.fmi = int(md.fmiVersion[0])
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.outputs = [v.name for v in md.modelVariables if v.causality == "output"]
        cls = FMU2Slave if self.fmi == 2 else FMU3Slave
        self.fmu = cls(
            guid=md.guid,
            unzipDirectory=extract(fmu_path, unzipdir=os.path.join(folder, name)),
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        self.fmu.instantiate()
        if self.fmi == 2:
            self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for p in bindings:
            setter = self.fmu.setBoolean if p.type == "Boolean" else self.set
            value = p.value in (True, "true", "1") if p.type == "Boolean" else float(p.value)
            setter([self.vr[p.name]], [value])
        self.fmu.exitInitializationMode()

    def get(self, refs):
        return self.fmu.getReal(refs) if self.fmi == 2 else self.fmu.getFloat64(refs)

    def set(self, refs, values):
        return (
            self.fmu.setReal(refs, values) if self.fmi == 2 else self.fmu.setFloat64(refs, values)
        )


def _propagate(components, wires):
    """Sweep the connections (read, then set) until no input changes; the sweeps taken."""
    last = None
    for sweep in range(1, MAX_SWEEPS + 1):
        values = []
        for a, avr, b, bvr in wires:
            value = components[a].get([avr])[0]
            components[b].set([bvr], [value])
            values.append(value)
        if last is not None and np.allclose(values, last, rtol=1e-12, atol=0.0):
            return sweep
        last = values
    raise RuntimeError(f"the connections' values did not settle in {MAX_SWEEPS} sweeps")


def run(ssp_path=DEFAULT_SSP, duration=30.0, step=1e-3):
    """Simulate the SSP, setting every input before reading the outputs that depend on it.

    Parameters
    ----------
    ssp_path : str
        The ``.ssp`` file (FMI 2.0 or 3.0 co-simulation FMUs).
    duration : float
        Simulated time, s.
    step : float
        Communication step, s.

    Returns
    -------
    dict of str to ndarray
        ``time`` [s] (``0, h, 2h, ...``) and every output of every component,
        ``"<component>.<variable>"``, at those times (row 0: after initialization, the
        connections settled), and ``sweeps``: the sweeps each point took.
    """
    from fmpy.ssp.ssd import read_ssd

    system = read_ssd(str(ssp_path)).system
    params = parameter_set(ssp_path).parameters
    folder = tempfile.mkdtemp(prefix="bodyvib-set-then-read-")
    components = {}
    try:
        with zipfile.ZipFile(ssp_path) as z:
            z.extractall(os.path.join(folder, "ssp"))
        for el in system.elements:
            mine = [p for p in params if p.name.startswith(el.name + ".")]
            for p in mine:
                p.name = p.name[len(el.name) + 1 :]
            fmu = os.path.join(folder, "ssp", el.source)
            components[el.name] = _Component(el.name, fmu, mine, folder)
        wires = [
            (
                c.startElement,
                components[c.startElement].vr[c.startConnector],
                c.endElement,
                components[c.endElement].vr[c.endConnector],
            )
            for c in system.connections
        ]
        recorded = [(n, c, c.vr[o]) for n, c in components.items() for o in c.outputs]
        names = [f"{n}.{o}" for n, c in components.items() for o in c.outputs]
        n = int(round(duration / step)) + 1
        rows, sweeps = np.empty((n, len(recorded))), np.empty(n, dtype=int)
        for k in range(n):
            if k:
                for comp in components.values():
                    comp.fmu.doStep((k - 1) * step, step)
            sweeps[k] = _propagate(components, wires)
            rows[k] = [comp.get([vr])[0] for _, comp, vr in recorded]
        out = {"time": np.arange(n) * step, "sweeps": sweeps}
        out.update(zip(names, rows.T))
        return out
    finally:
        for comp in components.values():
            comp.fmu.terminate()
            comp.fmu.freeInstance()
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main(run)
