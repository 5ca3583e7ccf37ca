"""Output files: atomic writes through symlinks, kept modes, refused special files,
staged (all-or-none) commits, output paths checked before work, JSON without NaN."""

import json
import math
import os
import stat

import pytest

from bodyvib.process.outputs import (
    PendingFile,
    atomic_write_bytes,
    atomic_write_text,
    check_outputs,
    open_staged,
    staged_writes,
    write_json,
)
from bodyvib.runtime.errors import BodyvibError


def _no_temporaries(folder):
    return not [p for p in os.listdir(folder) if p.startswith(".tmp-")]


def test_symlink_is_written_through_to_its_target(tmp_path):
    target = tmp_path / "real.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    atomic_write_text(link, "new")
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text() == "new"
    assert _no_temporaries(tmp_path)


def test_existing_file_keeps_its_mode(tmp_path):
    p = tmp_path / "a.txt"
    p.write_text("old")
    p.chmod(0o640)
    atomic_write_text(p, "new")
    assert stat.S_IMODE(os.stat(p).st_mode) == 0o640 and p.read_text() == "new"


def test_read_only_file_is_refused_or_keeps_its_mode(tmp_path):
    """A user cannot overwrite a read-only file (as open() would refuse); root can, and the
    file stays read-only (the replacement file keeps the mode, not 0644)."""
    p = tmp_path / "a.txt"
    p.write_text("old")
    p.chmod(0o444)
    if os.access(p, os.W_OK):  # root
        atomic_write_text(p, "new")
        assert p.read_text() == "new"
    else:
        with pytest.raises(BodyvibError, match="read-only"):
            atomic_write_text(p, "new")
        assert p.read_text() == "old"
    assert stat.S_IMODE(os.stat(p).st_mode) == 0o444


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda p: os.mkfifo(p), "FIFO"),
        (lambda p: os.mkdir(p), "folder"),
    ],
)
def test_special_destinations_are_refused(tmp_path, make, words):
    p = tmp_path / "out.json"
    make(p)
    with pytest.raises(BodyvibError, match=words):
        atomic_write_text(p, "x")
    with pytest.raises(BodyvibError, match=words):
        check_outputs([("--json", str(p), (".json",))])
    assert _no_temporaries(tmp_path)


def test_device_is_refused():
    with pytest.raises(BodyvibError, match="character device"):
        atomic_write_bytes("/dev/null", b"x")
    with pytest.raises(BodyvibError, match="character device"):
        check_outputs([("--csv", "/dev/null", None)])


def test_staged_writes_commit_all_or_none(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.csv"
    a.write_text("old a")
    with pytest.raises(RuntimeError):
        with staged_writes():
            atomic_write_text(a, "new a")
            with open_staged(b) as f:
                f.write("new b")
            assert a.read_text() == "old a" and not b.exists()  # nothing placed yet
            raise RuntimeError("a later step fails")
    assert a.read_text() == "old a" and not b.exists() and _no_temporaries(tmp_path)
    with staged_writes() as st:
        atomic_write_text(a, "new a")
        with open_staged(b) as f:
            f.write("new b")
    assert a.read_text() == "new a" and b.read_text() == "new b" and st.paths == [str(a), str(b)]
    assert _no_temporaries(tmp_path)


def test_staged_outputs_whose_folder_vanished_are_all_refused(tmp_path):
    """The output folder removed while the command runs: the CSV streamed there is gone, so
    the JSON written after it (into the folder made again) must not be placed either."""
    import shutil

    gone = tmp_path / "gone"
    with pytest.raises(BodyvibError, match="vanished"):
        with staged_writes():
            csv = PendingFile(gone / "r.csv")
            csv.file.write("t,x\n")
            shutil.rmtree(gone)  # the user removes the folder mid-run
            csv.place()
            atomic_write_text(gone / "r.json", "{}")
    assert not gone.exists() and list(tmp_path.iterdir()) == []


def test_a_streamed_file_takes_the_folders_made_for_it_when_discarded(tmp_path):
    """A CSV streamed into folders that did not exist (``cosim --csv out/run/r.csv``)
    removes them with itself when the run stops (a signal), before or inside the staged
    block; placed and committed, they stay."""
    out = tmp_path / "out"
    csv = PendingFile(out / "run" / "r.csv")
    csv.file.write("t,x\n")
    assert (out / "run").is_dir()
    csv.discard()
    assert list(tmp_path.iterdir()) == []

    csv = PendingFile(out / "run" / "r.csv")
    with pytest.raises(KeyboardInterrupt):
        with staged_writes():
            csv.place()
            raise KeyboardInterrupt  # stopped after the CSV, before the other outputs
    csv.discard()
    assert list(tmp_path.iterdir()) == []

    csv = PendingFile(out / "run" / "r.csv")
    with staged_writes():
        csv.file.write("t,x\n")
        csv.place()
    csv.discard()  # a no-op once placed
    assert (out / "run" / "r.csv").read_text() == "t,x\n"


def test_a_failed_rename_undoes_the_renames_before_it(tmp_path, monkeypatch):
    """All or none when the second of two renames fails: the first destination gets its old
    content back, a new one is removed."""
    a, b, c = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "c.json"
    a.write_text("old a")
    real_replace = os.replace

    def replace(src, dst):
        if os.fspath(dst).endswith("c.json"):
            raise OSError(28, "No space left on device")
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OSError, match="No space"):
        with staged_writes():
            atomic_write_text(a, "new a")
            atomic_write_text(b, "new b")
            atomic_write_text(c, "new c")
    monkeypatch.undo()
    assert a.read_text() == "old a" and not b.exists() and not c.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]


def test_output_that_is_an_input_is_refused(tmp_path):
    inp = tmp_path / "r.json"
    inp.write_text("{}")
    link = tmp_path / "alias.json"
    link.symlink_to(inp)
    for out in (inp, link, tmp_path / "." / "r.json"):
        with pytest.raises(BodyvibError, match="is the input of --reference"):
            check_outputs([("--out", str(out), (".json",))], inputs=[("--reference", str(inp))])
    assert inp.read_text() == "{}"


def test_two_outputs_on_one_file_and_bad_extension_are_refused(tmp_path):
    with pytest.raises(BodyvibError, match="name the same file"):
        check_outputs(
            [("--json", str(tmp_path / "x.json"), None), ("--csv", str(tmp_path / "x.json"), None)]
        )
    with pytest.raises(BodyvibError, match=r"must end in \.png"):
        check_outputs([("--plot", str(tmp_path / "result.txt"), (".png", ".pdf", ".svg"))])
    (tmp_path / "f").write_text("")
    with pytest.raises(BodyvibError, match="is a file, not a folder"):
        check_outputs([("--json", str(tmp_path / "f" / "x.json"), None)])


def test_json_refuses_nan_and_infinity(tmp_path):
    p = tmp_path / "x.json"
    p.write_text("old")
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(BodyvibError, match=r"\$\.models\.a\.modulus\[1\] is not a finite"):
            write_json(p, {"models": {"a": {"modulus": [1.0, bad]}}})
    assert p.read_text() == "old"
    write_json(p, {"x": [1.0, 2.5]})
    assert json.loads(p.read_text()) == {"x": [1.0, 2.5]}
