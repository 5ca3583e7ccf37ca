"""The sweep table on disk: columns and units, provenance, parts, and the final file.

A running sweep writes each finished task as one Parquet *part* in
``OUT.parts/`` (:func:`write_part`); :func:`scan` reads back only the key
columns of ``OUT`` and its parts (what is done, what failed), and
:func:`assemble` streams the chosen rows into the final Parquet file (and the
CSV) window by window in ``case_id`` order, so that neither a million rows nor
their keys' full records are held at once.

Units: every column's unit is in its Parquet field metadata (``b"unit"``), in
the file metadata (``b"bodyvib.units"``, JSON), and in the CSV header as
``name [unit]`` (dimensionless columns carry no bracket). The file metadata
also holds the provenance of the run (:func:`provenance`): the spec itself,
bodyvib's version and git commit (when it runs from a checkout), the versions
of Python, numpy, scipy, pandas, pyarrow and dask, and a UTC timestamp.
"""

import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

from bodyvib import __version__
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.renames import warn_renamed

__all__ = [
    "CASE_COLUMNS",
    "RENAMED_COLUMNS",
    "current_columns",
    "TRAILING_COLUMNS",
    "FIGURE_UNITS",
    "REPLACES_OUT",
    "table_schema",
    "units",
    "csv_header",
    "provenance",
    "parts_dir",
    "part_name",
    "part_bytes",
    "arrow_array",
    "write_part",
    "Scan",
    "scan",
    "assemble",
]

#: Case columns before the model parameters, with units.
CASE_COLUMNS = (
    ("case_id", ""),
    ("case_key", ""),
    ("road", ""),
    ("seed", ""),
    ("speed", "m/s"),
    ("duration", "s"),
    ("step", "s"),
    ("body", ""),
    ("body_model", ""),
    ("body_sample", ""),
    ("car", ""),
)
#: Case columns renamed (old -> new): a table written before reads with the new names.
RENAMED_COLUMNS = {"speed_m_s": "speed", "duration_s": "duration", "step_s": "step"}

#: Units of the figure columns (a figure not listed here has none).
FIGURE_UNITS = {
    "head_weighted_rms": "m/s2",
    "head_vdv": "m/s^1.75",
    "head_peak": "m/s2",
    "head_crest_factor": "",
    "head_comfort": "",
    "head_comfort_method": "",
    "seat_weighted_rms": "m/s2",
    "head_mtvv": "m/s2",
    "neck_force_peak": "N",
    "lumbar_force_peak": "N",
    "seat_aw_x": "m/s2",
    "seat_aw_y": "m/s2",
    "seat_aw_z": "m/s2",
    "seat_av": "m/s2",
    "seat_aw_rx": "rad/s2",
    "seat_aw_ry": "rad/s2",
    "seat_rotation_av": "m/s2",
    "lift_offs": "",
    "time_in_air": "s",
    "stop_contacts": "",
    "largest_stop_force": "N",
    "smallest_tire_load_ratio": "",
    "stepping": "",
}
#: Columns after the figures.
TRAILING_COLUMNS = ("engine", "engine_settings", "error", "bodyvib_version", "spec_hash", "run_id")
_INTS = {"case_id", "seed", "body_sample"}
_STRINGS = {
    "case_key",
    "road",
    "body",
    "body_model",
    "car",
    "head_comfort",
    "head_comfort_method",
    "stepping",
} | set(TRAILING_COLUMNS)
WINDOW = 16384  # rows assembled at a time


def table_schema(body_units: Dict[str, str], car_units: Dict[str, str], figures: Sequence[str]):
    """The Arrow schema of a sweep table, each field with its unit in its metadata.

    Parameters
    ----------
    body_units, car_units : dict
        Parameter name -> unit of every body (car) model of the sweep: one
        ``body_<name>`` (``car_<name>``) column each.
    figures : sequence of str
        The engines' figure columns.

    Returns
    -------
    pyarrow.Schema

    Examples
    --------
    >>> s = table_schema({"m1": "kg"}, {"ms": "kg"}, ["head_weighted_rms"])
    >>> s.field("body_m1").metadata[b"unit"], s.field("head_weighted_rms").metadata[b"unit"]
    (b'kg', b'm/s2')
    """
    import pyarrow as pa

    cols = list(CASE_COLUMNS)
    cols += [(f"body_{p}", u) for p, u in body_units.items()]
    cols += [(f"car_{p}", u) for p, u in car_units.items()]
    cols += [(f, FIGURE_UNITS.get(f, "")) for f in figures]
    cols += [(c, "") for c in TRAILING_COLUMNS]
    fields = []
    for name, unit in cols:
        t = pa.int64() if name in _INTS else pa.string() if name in _STRINGS else pa.float64()
        fields.append(pa.field(name, t, metadata={"unit": unit}))
    return pa.schema(fields)


def units(schema) -> Dict[str, str]:
    """Column name -> unit ("" for none) from a sweep schema's field metadata.

    Parameters
    ----------
    schema : pyarrow.Schema

    Returns
    -------
    dict
    """
    return {f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in schema}


def csv_header(schema) -> List[str]:
    """CSV column names: ``name [unit]`` (or ``name`` for a dimensionless column).

    Parameters
    ----------
    schema : pyarrow.Schema

    Returns
    -------
    list of str
    """
    return [f"{n} [{u}]" if u else n for n, u in units(schema).items()]


def _git_commit() -> Optional[str]:
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        r = subprocess.run(
            ["git", "-C", here, "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5
        )
        commit = r.stdout.strip()
        if r.returncode or len(commit) != 40:
            return None
        dirty = subprocess.run(
            ["git", "-C", here, "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=5,
        ).stdout.strip()
        return commit + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return None


def provenance(spec: dict, engine: str) -> Dict[str, str]:
    """What made a sweep table: file metadata (str -> str) for its Parquet schema.

    Parameters
    ----------
    spec : dict
        The sweep spec as given.
    engine : str

    Returns
    -------
    dict
        ``bodyvib.spec`` (JSON), ``bodyvib.engine``, ``bodyvib.version``,
        ``bodyvib.commit`` (empty when not known), ``bodyvib.versions`` (JSON:
        python, numpy, scipy, pandas, pyarrow, dask, distributed),
        ``bodyvib.created`` (UTC, ISO 8601).
    """
    from importlib import metadata

    versions = {"python": sys.version.split()[0]}
    for pkg in ("numpy", "scipy", "pandas", "pyarrow", "dask", "distributed"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = ""
    return {
        "bodyvib.spec": json.dumps(spec, sort_keys=True, default=str),
        "bodyvib.engine": engine,
        "bodyvib.version": __version__,
        "bodyvib.commit": _git_commit() or "",
        "bodyvib.versions": json.dumps(versions, sort_keys=True),
        "bodyvib.created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def parts_dir(out: str) -> str:
    """Folder holding the per-task files of a running sweep (``OUT.parts``).

    Parameters
    ----------
    out : str
        The sweep's output file.

    Returns
    -------
    str

    Examples
    --------
    >>> parts_dir("results.parquet")
    'results.parquet.parts'
    """
    return os.fspath(out) + ".parts"


def part_name(start_ns: int, run_id: str, task_no: int) -> str:
    """File name of a part: sorts by the run's start time, then task number."""
    return f"part-{start_ns:020d}-{run_id}-{task_no:08d}.parquet"


def part_bytes(columns: Dict[str, list], schema) -> bytes:
    """One task's rows as a Parquet file's bytes (made where the task ran).

    Parameters
    ----------
    columns : dict
        Column name -> values (every column of ``schema``).
    schema : pyarrow.Schema

    Returns
    -------
    bytes
    """
    import io

    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays = [arrow_array(columns[f.name], f.type) for f in schema]
    buf = io.BytesIO()
    pq.write_table(pa.Table.from_arrays(arrays, schema=schema), buf)
    return buf.getvalue()


def arrow_array(values: Sequence, arrow_type):
    """A column of a sweep table as an Arrow array, built from its buffers.

    The same array as ``pyarrow.array(values, type)``, for the three types of a
    sweep table, made without pyarrow's conversion of Python objects: that
    conversion first checks whether the values are a pandas object, which imports
    pandas (about 0.25 s of CPU, in each Dask worker's first task).

    Parameters
    ----------
    values : sequence
        Python (or numpy) numbers or strings; None is a null.
    arrow_type : pyarrow.DataType
        ``int64``, ``float64`` or ``string``.

    Returns
    -------
    pyarrow.Array

    Raises
    ------
    TypeError
        Another type, or a string column with a value that is not a string.

    Examples
    --------
    >>> import pyarrow as pa
    >>> arrow_array([1.5, None, float("nan")], pa.float64()).to_pylist()
    [1.5, None, nan]
    >>> arrow_array(["B", None, "é"], pa.string()).equals(pa.array(["B", None, "é"]))
    True
    """
    import numpy as np
    import pyarrow as pa

    n = len(values)
    valid = np.fromiter((v is not None for v in values), bool, n)
    nulls = n - int(np.count_nonzero(valid))
    # validity bitmap: bit i (least significant first) set for a value
    bitmap = pa.py_buffer(np.packbits(valid, bitorder="little")) if nulls else None
    if arrow_type == pa.string():
        try:
            data = [b"" if v is None else v.encode("utf-8") for v in values]
        except AttributeError:
            bad = next(v for v in values if v is not None and not isinstance(v, str))
            raise TypeError(f"a string column holds {type(bad).__name__} {bad!r}") from None
        offsets = np.zeros(n + 1, np.int32)
        np.cumsum(np.fromiter(map(len, data), np.int64, n), out=offsets[1:])
        buffers = [bitmap, pa.py_buffer(offsets), pa.py_buffer(b"".join(data))]
    elif arrow_type in (pa.int64(), pa.float64()):
        dtype = np.int64 if arrow_type == pa.int64() else np.float64
        zero = dtype(0)
        data = np.fromiter((zero if v is None else v for v in values), dtype, n)
        buffers = [bitmap, pa.py_buffer(data)]
    else:
        raise TypeError(f"no sweep column has the Arrow type {arrow_type}")
    return pa.Array.from_buffers(arrow_type, n, buffers, null_count=nulls)


def write_part(folder: str, name: str, data: bytes) -> None:
    """Write one task's Parquet bytes as a part, atomically.

    Parameters
    ----------
    folder : str
        ``OUT.parts``; created if missing.
    name : str
        :func:`part_name`.
    data : bytes
        :func:`part_bytes`.
    """
    from bodyvib.process.outputs import atomic_write_bytes

    atomic_write_bytes(os.path.join(folder, name), data)


#: A file in ``OUT.parts/`` saying that the parts replace ``OUT`` (a run with ``--overwrite``).
REPLACES_OUT = ".replaces-out"


def _sources(out: Optional[str], folder: Optional[str] = None) -> List[str]:
    folder = folder or parts_dir(out)
    replaced = os.path.exists(os.path.join(folder, REPLACES_OUT))
    files = [out] if out is not None and os.path.isfile(out) and not replaced else []
    if os.path.isdir(folder):
        files += [
            os.path.join(folder, f)
            for f in sorted(os.listdir(folder))
            if f.endswith(".parquet") and not f.startswith(".")
        ]
    return files


@dataclass
class Scan:
    """What an output holds so far: per stored row, its source, ``case_id`` and success.

    Within one spec a ``case_id`` names one case (resuming refuses rows of
    another spec), so numbers are all the bookkeeping holds: 13 bytes per stored
    row, none per case of the spec.

    Attributes
    ----------
    sources : list of str
        ``OUT`` (if it exists), then the parts, oldest first.
    src, case_id : ndarray of int
        Per stored row: its source (position in ``sources``) and case.
    ok : ndarray of bool
        Per stored row: no error.
    spec_hashes : set of str
        The spec hashes found.
    """

    sources: List[str]
    src: object
    case_id: object
    ok: object
    spec_hashes: set

    @property
    def rows(self) -> int:
        """Stored rows (duplicates included)."""
        return len(self.case_id)

    def done(self, count: int, retry_failed: bool = False):
        """Boolean mask over the spec's ``count`` cases: stored (or, with ``retry_failed``, stored without error)."""
        import numpy as np

        mask = np.zeros(count, dtype=bool)
        ids = self.case_id[self.ok] if retry_failed else self.case_id
        mask[ids[ids < count]] = True
        return mask

    def failed(self) -> int:
        """Number of stored cases with an error and no successful row."""
        import numpy as np

        return int(np.setdiff1d(self.case_id[~self.ok], self.case_id[self.ok]).size)


def scan(out: Optional[str], folder: Optional[str] = None) -> Scan:
    """Read the bookkeeping columns of ``OUT`` and ``OUT.parts/``.

    Parameters
    ----------
    out : str or None
        The output file (None: parts only).
    folder : str, optional
        The parts folder (default ``OUT.parts``).

    Returns
    -------
    Scan

    Raises
    ------
    BodyvibError
        A file that is not a sweep table.
    """
    import numpy as np
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    sources = _sources(out, folder)
    srcs, ids, oks, hashes = [], [], [], set()
    for i, f in enumerate(sources):
        try:
            t = pq.read_table(f, columns=["case_id", "error", "spec_hash"])
        except Exception as exc:
            raise BodyvibError(
                f"'{f}' is not a readable sweep table ({exc}); move it away or pass overwrite=True",
                parameters=("overwrite",),
            ) from None
        ids.append(t["case_id"].to_numpy())
        oks.append(t["error"].is_null().to_numpy(zero_copy_only=False))
        srcs.append(np.full(t.num_rows, i, dtype=np.int32))
        hashes.update(pc.unique(t["spec_hash"]).to_pylist())

    def cat(xs, dt):
        return np.concatenate(xs) if xs else np.empty(0, dt)

    return Scan(sources, cat(srcs, np.int32), cat(ids, np.int64), cat(oks, bool), hashes)


def _selection(found: Scan):
    """One stored row per case: ``(case_id, src)`` sorted by case, a successful row (the
    oldest) where there is one, else the newest failure."""
    import numpy as np

    rank = np.where(found.ok, found.src, -found.src)
    order = np.lexsort((rank, ~found.ok, found.case_id))
    ids = found.case_id[order]
    first = np.ones(len(ids), dtype=bool)
    first[1:] = ids[1:] != ids[:-1]
    return ids[first], found.src[order][first]


def _read_range(path: str, lo: int, hi: int):
    """The row groups of a Parquet file whose ``case_id`` range meets ``[lo, hi]`` (one thread)."""
    import pyarrow.parquet as pq

    f = pq.ParquetFile(path)
    col = f.schema_arrow.get_field_index("case_id")
    groups = []
    for g in range(f.num_row_groups):
        st = f.metadata.row_group(g).column(col).statistics
        if st is None or not st.has_min_max or (st.min <= hi and st.max >= lo):
            groups.append(g)
    return current_columns(f.read_row_groups(groups, use_threads=False), path)


def current_columns(table, source: str):
    """``table`` with the case columns of an older table under their current names, warned.

    Parameters
    ----------
    table : pyarrow.Table or pyarrow.Schema
        Rows of a sweep table, or its schema.
    source : str
        Its file, for the warning.

    Returns
    -------
    pyarrow.Table or pyarrow.Schema
        The same object when no column is renamed.
    """
    import pyarrow as pa

    schema = table if isinstance(table, pa.Schema) else table.schema
    old = [n for n in schema.names if n in RENAMED_COLUMNS]
    if not old:
        return table
    for n in old:
        warn_renamed(f"sweep table '{source}'", n, RENAMED_COLUMNS[n])
    new = pa.schema(
        [f.with_name(RENAMED_COLUMNS.get(f.name, f.name)) for f in schema], schema.metadata
    )
    return new if isinstance(table, pa.Schema) else table.rename_columns(new.names)


def assemble(found: Scan, schema, out_file=None, csv_file=None, check=None) -> int:
    """Stream one row per case of the scanned sources into Parquet and/or CSV, by ``case_id``.

    Parameters
    ----------
    found : Scan
        The sources and their bookkeeping (:func:`scan`).
    schema : pyarrow.Schema
        The table's schema with its file metadata.
    out_file, csv_file : binary file object, optional
        Where to write (e.g. :func:`bodyvib.process.outputs.open_staged`).
    check : callable, optional
        Called between windows (an interrupt's safe point).

    Returns
    -------
    int
        Rows written.
    """
    import numpy as np
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    ids, srcs = _selection(found)
    lo_src = np.full(len(found.sources), np.iinfo(np.int64).max)
    hi_src = np.full(len(found.sources), -1)
    np.minimum.at(lo_src, srcs, ids)
    np.maximum.at(hi_src, srcs, ids)
    writer = pq.ParquetWriter(out_file, schema) if out_file is not None else None
    # (row groups of WINDOW rows: a resume reads back only the groups it needs)
    csv_schema = pa.schema([f.with_name(n) for f, n in zip(schema, csv_header(schema))])
    csv_writer = pacsv.CSVWriter(csv_file, csv_schema) if csv_file is not None else None
    pool = pa.default_memory_pool()
    written = 0
    try:
        for a in range(0, len(ids), WINDOW):
            if check is not None:
                check()
            w_ids, w_src = ids[a : a + WINDOW], srcs[a : a + WINDOW]
            lo, hi = int(w_ids[0]), int(w_ids[-1])
            pieces = []
            for src in np.flatnonzero((lo_src <= hi) & (hi_src >= lo)):
                want = w_ids[w_src == src]
                if not len(want):
                    continue
                t = _read_range(found.sources[src], int(want[0]), int(want[-1]))
                t = t.filter(pc.is_in(t["case_id"], value_set=pa.array(want)))
                pieces.append(t.select(schema.names).cast(schema))
            table = (
                pa.concat_tables(pieces).sort_by("case_id").replace_schema_metadata(schema.metadata)
            )
            if writer is not None:
                writer.write_table(table)
            if csv_writer is not None:
                csv_writer.write_table(table.rename_columns(csv_schema.names).cast(csv_schema))
            written += table.num_rows
            del table, pieces
            pool.release_unused()
        if writer is not None and not written:
            writer.write_table(schema.empty_table())
    finally:
        if writer is not None:
            writer.close()
        if csv_writer is not None:
            csv_writer.close()
    return written
