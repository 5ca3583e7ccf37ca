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

__all__ = ["CASE_COLUMNS", "TRAILING_COLUMNS", "FIGURE_UNITS", "table_schema", "provenance",
           "parts_dir", "part_name", "REPLACES_OUT", "part_bytes", "write_part", "Scan", "scan", "assemble", "csv_header"]

#: Case columns before the model parameters, with units.
CASE_COLUMNS = (("case_id", ""), ("case_key", ""), ("road", ""), ("seed", ""),
                ("speed_m_s", "m/s"), ("duration_s", "s"), ("step_s", "s"), ("body", ""),
                ("body_model", ""), ("body_sample", ""), ("car", ""))
#: Units of the figure columns (a figure not listed here has none).
FIGURE_UNITS = {"head_weighted_rms": "m/s2", "head_vdv": "m/s^1.75", "head_peak": "m/s2",
                "head_crest_factor": "", "head_comfort": "", "seat_weighted_rms": "m/s2"}
#: Columns after the figures.
TRAILING_COLUMNS = ("engine", "engine_settings", "error", "bodyvib_version", "spec_hash",
                    "run_id")
_INTS = {"case_id", "seed", "body_sample"}
_STRINGS = {"case_key", "road", "body", "body_model", "car", "head_comfort"} | set(TRAILING_COLUMNS)
WINDOW = 65536  # rows assembled at a time


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


def _units(schema) -> Dict[str, str]:
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
    return [f"{n} [{u}]" if u else n for n, u in _units(schema).items()]


def _git_commit() -> Optional[str]:
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        r = subprocess.run(["git", "-C", here, "rev-parse", "HEAD"], capture_output=True,
                           text=True, timeout=5)
        commit = r.stdout.strip()
        if r.returncode or len(commit) != 40:
            return None
        dirty = subprocess.run(["git", "-C", here, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=5).stdout.strip()
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
    return {"bodyvib.spec": json.dumps(spec, sort_keys=True, default=str),
            "bodyvib.engine": engine, "bodyvib.version": __version__,
            "bodyvib.commit": _git_commit() or "",
            "bodyvib.versions": json.dumps(versions, sort_keys=True),
            "bodyvib.created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}


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

    buf = io.BytesIO()
    pq.write_table(pa.Table.from_pydict(columns, schema=schema), buf)
    return buf.getvalue()


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
        files += [os.path.join(folder, f) for f in sorted(os.listdir(folder))
                  if f.endswith(".parquet") and not f.startswith(".")]
    return files


@dataclass
class Scan:
    """What an output holds so far (key columns only).

    Attributes
    ----------
    sources : list of str
        ``OUT`` (if it exists), then the parts, oldest first.
    index : pandas.DataFrame or None
        One row per stored row: ``src`` (position in ``sources``), ``case_id``,
        ``case_key``, ``ok`` (no error), ``spec_hash``.
    """

    sources: List[str]
    index: object

    def done(self, retry_failed: bool = False) -> set:
        """Keys of the cases not to run again (every stored case, or only those that succeeded)."""
        if self.index is None:
            return set()
        idx = self.index[self.index["ok"]] if retry_failed else self.index
        return set(idx["case_key"])

    def failed(self) -> int:
        """Number of stored cases with an error and no successful row."""
        if self.index is None:
            return 0
        ok = set(self.index.loc[self.index["ok"], "case_key"])
        return len(set(self.index.loc[~self.index["ok"], "case_key"]) - ok)


def scan(out: Optional[str], folder: Optional[str] = None) -> Scan:
    """Read the key columns of ``OUT`` and ``OUT.parts/``.

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
    import pandas as pd
    import pyarrow.parquet as pq

    sources = _sources(out, folder)
    frames = []
    for i, f in enumerate(sources):
        try:
            t = pq.read_table(f, columns=["case_id", "case_key", "error", "spec_hash"])
        except Exception as exc:
            raise BodyvibError(f"'{f}' is not a readable sweep table ({exc}); move it away or "
                               "pass --overwrite") from None
        df = pd.DataFrame({"src": i, "case_id": t["case_id"].to_numpy(),
                           "case_key": t["case_key"].to_pandas(),
                           "ok": t["error"].is_null().to_numpy(zero_copy_only=False),
                           "spec_hash": t["spec_hash"].to_pandas()})
        frames.append(df)
    index = pd.concat(frames, ignore_index=True) if frames else None
    return Scan(sources, index)


def _selection(index):
    """One stored row per case: a successful one (the oldest), else the newest failure."""
    rank = index["src"].where(index["ok"], -index["src"])
    order = index.assign(_bad=~index["ok"], _rank=rank).sort_values(["_bad", "_rank"],
                                                                      kind="stable")
    return order.drop_duplicates("case_key")[["src", "case_id", "case_key"]].sort_values(
        "case_id", kind="stable").reset_index(drop=True)


def assemble(sources: Sequence[str], index, schema, out_file=None, csv_file=None,
             check=None) -> int:
    """Stream the chosen rows of the sources into a Parquet and/or a CSV file, by ``case_id``.

    Parameters
    ----------
    sources : sequence of str
        Parquet files (:attr:`Scan.sources`).
    index : pandas.DataFrame
        :attr:`Scan.index` of those sources.
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
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    sel = _selection(index)
    bounds = sel.groupby("src")["case_id"].agg(["min", "max"])
    writer = pq.ParquetWriter(out_file, schema) if out_file is not None else None
    csv_schema = pa.schema([f.with_name(n) for f, n in zip(schema, csv_header(schema))])
    csv_writer = pacsv.CSVWriter(csv_file, csv_schema) if csv_file is not None else None
    written = 0
    try:
        for a in range(0, len(sel), WINDOW):
            if check is not None:
                check()
            win = sel.iloc[a:a + WINDOW]
            lo, hi = int(win["case_id"].iloc[0]), int(win["case_id"].iloc[-1])
            pieces = []
            for src in bounds.index[(bounds["min"] <= hi) & (bounds["max"] >= lo)]:
                keys = win.loc[win["src"] == src, "case_key"]
                if not len(keys):
                    continue
                t = pq.read_table(sources[src], filters=[("case_id", ">=", lo),
                                                         ("case_id", "<=", hi)])
                t = t.filter(pc.is_in(t["case_key"], value_set=pa.array(keys.tolist())))
                pieces.append(t.select(schema.names).cast(schema))
            table = pa.concat_tables(pieces).sort_by("case_id").replace_schema_metadata(
                schema.metadata)
            if writer is not None:
                writer.write_table(table)
            if csv_writer is not None:
                csv_writer.write_table(table.rename_columns(csv_schema.names).cast(csv_schema))
            written += table.num_rows
        if writer is not None and not written:
            writer.write_table(schema.empty_table())
    finally:
        if writer is not None:
            writer.close()
        if csv_writer is not None:
            csv_writer.close()
    return written
