"""A tabulated signal source FMU kind: profiles over a coordinate, driven through at a speed.

A source FMU has no inputs. It carries a table of profiles ``z_c(p)`` over a
coordinate ``p`` (for a road: the distance, m) with their slopes ``dz_c/dp``,
and a parameter ``speed`` that turns time into the coordinate, ``p = speed * t``.
Each profile gives two outputs: its value ``z_c(p(t))`` and its time derivative
``speed * dz_c/dp``. Between the table's rows both come from one piecewise
cubic Hermite interpolant (values and slopes at the rows), so the rate output
is the exact derivative of the value output everywhere, not a second,
independently interpolated signal; at the rows both equal the tabulated ones.

Outside the table the profile repeats (``periodic``, e.g. a sum of harmonics
whose period is the table's length) or holds its end value with zero slope. A
periodic table may open with a lead-in driven once (``loop_row``: the row where
the repeating part starts), as a measured road faded in once and then repeated.

The source file (:data:`SOURCE_FILE` in the FMU's resources) is JSON::

    {"name": ..., "description": ...,
     "coordinate": {"name": "distance", "unit": "m"},
     "speed": {"name": "speed", "unit": "m/s", "start": 20.0, "description": ...},
     "signals": [{"name": "road_displacement", "unit": "m", "description": ...,
                  "rate": {"name": "road_velocity", "unit": "m/s", "description": ...}}],
     "periodic": true, "table": "bodyvib_table.csv", "provenance": {...}}

(plus ``"loop_row": n`` when the repeating part starts at row ``n``, not 0)

and the table a CSV file beside it: a header line, then rows ``p, z_1, dz_1/dp,
z_2, ...`` on a uniform, increasing grid of ``p``.

Numpy only, relative imports only: the FMUs ship this module under a private
package name.
"""

import json
import math
import os
from typing import TYPE_CHECKING, Callable, List, Optional, Sequence, Tuple, Union

import numpy as np

from .contract import PARAMETER_LIMITS, Interface, Variable
from .errors import BodyvibError
from .lifecycle import Lifecycle
from .renames import renamed_parameters

if TYPE_CHECKING:  # for annotations only: the FMU run-time does not import it
    from numpy.typing import ArrayLike

__all__ = ["SOURCE_FILE", "HermiteTable", "SourceCore", "read_source", "write_source"]

#: Where the build puts the source description, inside the FMU's resources.
SOURCE_FILE = "bodyvib_source.json"


class HermiteTable:
    """Piecewise cubic Hermite interpolation of profiles and their slopes on a uniform grid.

    Parameters
    ----------
    position : (k,) array_like
        Uniform, strictly increasing grid of the coordinate.
    value : (k, m) array_like
        Profiles at the grid points.
    slope : (k, m) array_like
        Their derivatives with respect to the coordinate.
    periodic : bool
        The profiles repeat with period ``position[-1] - position[loop]`` (the last
        row must then equal row ``loop``); otherwise they hold their end values.
    loop : int
        Periodic tables: the row where the repeating part starts. The rows before it
        are a lead-in, driven once (before it the first row is held); 0: the whole
        table repeats, in both directions.

    Raises
    ------
    BodyvibError
        Shapes that do not match, fewer than two rows, a grid that is not
        uniform and increasing, non-finite values, a loop row off the table or on a
        table that does not repeat, or a periodic table whose last row differs from
        its row ``loop``.

    Examples
    --------
    >>> t = HermiteTable([0.0, 1.0, 2.0], [[0.0], [1.0], [4.0]], [[0.0], [2.0], [4.0]])
    >>> z, dz = t.evaluate(1.5)
    >>> float(z[0]), float(dz[0])
    (2.25, 3.0)

    A lead-in (row 0 to 1) and then rows 1 to 3 again and again:

    >>> t = HermiteTable([0, 1, 2, 3], [0, 1, 2, 1], [0, 1, 0, 1], periodic=True, loop=1)
    >>> [float(t.evaluate(p)[0][0]) for p in (0.0, 1.0, 3.0, 5.0, 7.0)]
    [0.0, 1.0, 1.0, 1.0, 1.0]
    """

    def __init__(
        self,
        position: "ArrayLike",
        value: "ArrayLike",
        slope: "ArrayLike",
        periodic: bool = False,
        loop: int = 0,
    ) -> None:
        p = np.asarray(position, dtype=float)
        z = np.asarray(value, dtype=float)
        m = np.asarray(slope, dtype=float)
        if z.ndim == 1:
            z, m = z[:, None], m.reshape(-1, 1)
        if p.ndim != 1 or p.size < 2 or z.shape != (p.size, z.shape[1]) or m.shape != z.shape:
            raise BodyvibError(
                f"a source table needs >= 2 rows of position, values and slopes of "
                f"matching shapes; got {p.shape}, {z.shape}, {m.shape}"
            )
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(z)) and np.all(np.isfinite(m))):
            raise BodyvibError("source table holds a value that is not finite")
        d = np.diff(p)
        dp = (p[-1] - p[0]) / (p.size - 1)
        if not (dp > 0 and np.max(np.abs(d - dp)) <= 1e-9 * dp):
            raise BodyvibError("source table positions must be uniformly spaced and increasing")
        if not (isinstance(loop, (int, np.integer)) and 0 <= loop < p.size - 1):
            raise BodyvibError(
                f"source table loop row {loop!r} is off the table (0 to {p.size - 2})"
            )
        if loop and not periodic:
            raise BodyvibError("a source table that does not repeat has no loop row")
        if periodic and not (
            np.allclose(z[-1], z[loop], rtol=0, atol=1e-12 * (1 + np.abs(z).max()))
            and np.allclose(m[-1], m[loop], rtol=0, atol=1e-12 * (1 + np.abs(m).max()))
        ):
            raise BodyvibError(
                "a periodic source table must end where it starts (last row = first)"
                if not loop
                else "a periodic source table must end where its repeating part starts "
                f"(last row = row {loop})"
            )
        self.position, self.value, self.slope, self.periodic = p, z, m, bool(periodic)
        self.loop = int(loop)
        self._p0, self._dp, self._k = float(p[0]), float(dp), p.size - 1

    @property
    def length(self) -> float:
        """Extent of the table along the coordinate."""
        return self._dp * self._k

    def evaluate(self, p: "ArrayLike") -> Tuple[np.ndarray, np.ndarray]:
        """Values and slopes at coordinate ``p`` (scalar or array).

        Parameters
        ----------
        p : float or array_like

        Returns
        -------
        value, slope : ndarray
            Shape ``p.shape + (m,)``.
        """
        p = np.asarray(p, dtype=float)
        u = (p - self._p0) / self._dp
        if self.periodic and not self.loop:
            u = np.mod(u, self._k)
        elif self.periodic:  # past the end: back into the repeating part
            u = np.where(u > self._k, self.loop + np.mod(u - self.loop, self._k - self.loop), u)
        inside = (u >= 0) & (u <= self._k)
        uc = np.clip(u, 0, self._k)
        i = np.minimum(np.floor(uc).astype(int), self._k - 1)
        s = (uc - i)[..., None]
        z0, z1 = self.value[i], self.value[i + 1]
        m0, m1 = self.slope[i] * self._dp, self.slope[i + 1] * self._dp
        s2, s3 = s * s, s * s * s
        z = (
            (2 * s3 - 3 * s2 + 1) * z0
            + (s3 - 2 * s2 + s) * m0
            + (3 * s2 - 2 * s3) * z1
            + (s3 - s2) * m1
        )
        dz = (
            (6 * s2 - 6 * s) * (z0 - z1) + (3 * s2 - 4 * s + 1) * m0 + (3 * s2 - 2 * s) * m1
        ) / self._dp
        if not self.periodic or self.loop:  # beyond the ends: the end value, held
            dz = np.where(inside[..., None], dz, 0.0)
        return z, dz


@renamed_parameters(folder="dest")
def write_source(dest: Union[str, os.PathLike], meta: dict, table: HermiteTable) -> List[str]:
    """Write a source description and its table (what a source FMU carries).

    Parameters
    ----------
    dest : str or path
        Destination folder.
    meta : dict
        The JSON description (module docstring) without ``table`` and ``periodic``.
    table : HermiteTable

    Returns
    -------
    list of str
        The two file paths written (description, table).
    """
    meta = dict(meta, periodic=table.periodic, table=SOURCE_FILE.replace(".json", ".csv"))
    if table.loop:
        meta["loop_row"] = table.loop
    head = [meta["coordinate"]["name"]]
    for sig in meta["signals"]:
        head += [sig["name"], f"d{sig['name']}/d{meta['coordinate']['name']}"]
    cols = [table.position]
    for c in range(table.value.shape[1]):
        cols += [table.value[:, c], table.slope[:, c]]
    rows = np.column_stack(cols)
    paths = [os.path.join(dest, SOURCE_FILE), os.path.join(dest, meta["table"])]
    with open(paths[0], "w", encoding="utf-8") as f:
        json.dump(meta, f, indent=2)
        f.write("\n")
    with open(paths[1], "w", encoding="utf-8") as f:
        f.write(",".join(head) + "\n")
        for r in rows.tolist():
            f.write(",".join(repr(x) for x in r) + "\n")
    return paths


def read_source(path: str) -> Tuple[dict, HermiteTable]:
    """Read a source description and its table.

    Parameters
    ----------
    path : str
        The JSON description (its ``table`` is read from the same folder).

    Returns
    -------
    meta : dict
    table : HermiteTable

    Raises
    ------
    BodyvibError
        A missing or malformed file.
    """
    try:
        with open(path, encoding="utf-8") as f:
            meta = json.load(f)
        data = np.loadtxt(
            os.path.join(os.path.dirname(path), meta["table"]), delimiter=",", skiprows=1, ndmin=2
        )
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise BodyvibError(f"source file {path}: {exc}") from None
    try:
        loop = int(meta.get("loop_row", 0))
    except (TypeError, ValueError):
        raise BodyvibError(f"source file {path}: loop_row must be a row number") from None
    return meta, HermiteTable(
        data[:, 0], data[:, 1::2], data[:, 2::2], bool(meta.get("periodic")), loop
    )


class SourceCore(Lifecycle):
    """State and stepping of one source FMU instance (the :class:`bodyvib.runtime.engine.FmuCore` API).

    Parameters
    ----------
    meta : dict
        The source description (module docstring).
    table : HermiteTable
    name : str
        FMU name for messages.
    log : callable, optional
        ``log(message, level)``.

    Examples
    --------
    >>> meta = {"name": "ramp", "description": "", "coordinate": {"name": "distance", "unit": "m"},
    ...         "speed": {"name": "speed", "unit": "m/s", "start": 2.0, "description": "speed"},
    ...         "signals": [{"name": "z", "unit": "m", "description": "height",
    ...                      "rate": {"name": "v", "unit": "m/s", "description": "its rate"}}]}
    >>> core = SourceCore(meta, HermiteTable([0.0, 10.0], [[0.0], [1.0]], [[0.1], [0.1]]))
    >>> core.initialize()
    >>> core.do_step(0.0, 0.5)
    >>> [round(v, 12) for v in core.get_real([0, 1])]
    [0.1, 0.2]
    """

    kind = "source"

    def __init__(
        self,
        meta: dict,
        table: HermiteTable,
        name: str = "FMU",
        log: Optional[Callable[[str, str], None]] = None,
    ):
        self.name, self.meta, self.table, self._log = name, meta, table, log
        outputs = []
        for sig in meta["signals"]:
            rate = sig["rate"]
            outputs.append(
                Variable(sig["name"], "output", "continuous", sig["unit"], sig["description"])
            )
            outputs.append(
                Variable(rate["name"], "output", "continuous", rate["unit"], rate["description"])
            )
        if len(outputs) != 2 * table.value.shape[1]:
            raise BodyvibError(
                f"{name}: the source declares {len(outputs) // 2} signals, its table "
                f"holds {table.value.shape[1]}"
            )
        sp = meta["speed"]
        self.parameters = (
            Variable(
                sp["name"],
                "parameter",
                "fixed",
                sp["unit"],
                sp["description"],
                start=float(sp["start"]),
                min=PARAMETER_LIMITS[0],
            ),
        )
        self.interface = Interface(
            kind="source",
            inputs=(),
            outputs=tuple(outputs),
            input_map=np.zeros((0, 0)),
            rate_pairs=(),
            output_signals=tuple(v.name for v in outputs),
        )
        self.variables = self.interface.outputs + self.parameters
        self._no = len(outputs)
        self._speed = float(sp["start"])
        self._not_initialized()
        self.time = 0.0
        self._cache: Optional[List[float]] = None

    def setup_experiment(self, start_time: float) -> None:
        """Start time of the run (``fmi2SetupExperiment``)."""
        self.time = float(start_time)
        self._cache = None

    def check_parameters(self, params: Optional[np.ndarray] = None) -> None:
        """Refuse a speed that is not a positive finite number.

        Raises
        ------
        BodyvibError
        """
        speed = self._speed if params is None else float(params[0])
        self.parameters[0].check_positive(self.name, speed, "it")

    def initialize(self) -> None:
        """Validate the parameters (``fmi2ExitInitializationMode``).

        Raises
        ------
        BodyvibError
        """
        self._initialize(self.check_parameters, "set a valid value")
        self._cache = None

    def _outputs(self) -> List[float]:
        # not a cache of results across calls but the outputs at the current time and
        # speed, invalidated by every write of either: a host reads them one getReal at a
        # time, and each read would evaluate the whole road table again
        if self._cache is None:
            z, dz = self.table.evaluate(self._speed * self.time)
            out = []
            for c in range(z.shape[-1]):
                out += [float(z[c]), self._speed * float(dz[c])]
            self._cache = out
        return self._cache

    def get_real(self, vrs: Sequence[int]) -> List[float]:
        """Values by value reference: outputs at the current time, then the speed."""
        out = self._outputs() + [self._speed]
        return [out[vr] for vr in vrs]

    def set_real(self, vrs: Sequence[int], values: Sequence[float]) -> None:
        """Set the speed (before initialization); anything else is ignored with a logged error."""
        for vr, v in zip(vrs, values):
            if vr == self._no and not self._initialized:
                self._speed = float(v)
                self._cache = None
            elif vr == self._no:
                self._message(
                    f"{self.name}: parameter {self.parameters[0].name} is fixed after "
                    "initialization; set it before fmi2ExitInitializationMode (ignored)"
                )
            else:
                self._message(
                    f"{self.name}: {self.variables[vr].name} is an output and cannot be "
                    "set (ignored)"
                )

    def do_step(self, current_time: float, step_size: float) -> None:
        """Advance to ``current_time + step_size``; outputs are then those of that time.

        Raises
        ------
        BodyvibError
            Not initialized, or a step size that is not positive and finite.
        """
        if not 0.0 < step_size < math.inf:
            self._refuse_step_size(step_size)
        if not self._initialized:
            self._refuse_step()
        self.time = current_time + step_size
        self._cache = None

    def get_state(self) -> dict:
        """A JSON-serializable snapshot (``fmi2GetFMUstate``)."""
        return {"time": self.time, "speed": self._speed, "initialized": self._initialized}

    def set_state(self, state: dict) -> None:
        """Restore a snapshot from :meth:`get_state`."""
        self.time, self._speed = float(state["time"]), float(state["speed"])
        self._initialized = bool(state["initialized"])
        self._cache = None

    def output_dependencies(self) -> List[List[int]]:
        """No inputs: no output depends on one."""
        return [[] for _ in range(self._no)]
