"""bodyvib.runtime.teardown in plain Python (the FMU-hosted behaviour is tested under valgrind
in test_fmu_integration.py and test_fmu_c_host.py)."""

import atexit
import os
import sys
import threading

import pytest

from bodyvib.runtime import teardown as fmu_teardown

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux binaries only")


@pytest.fixture
def clean_registry(monkeypatch):
    """An empty registry; atexit registrations are recorded, not made."""
    handlers = []
    monkeypatch.setattr(fmu_teardown, "_binaries", [])
    monkeypatch.setattr(atexit, "register", handlers.append)
    return handlers


@linux
def test_binary_path_is_the_linux64_binary_beside_resources(tmp_path):
    resources = tmp_path / "fmu" / "resources"
    assert fmu_teardown.binary_path(str(resources), "HumanBody3DOF") == str(
        tmp_path / "fmu" / "binaries" / "linux64" / "HumanBody3DOF.so"
    )


@linux
def test_registration_is_once_per_binary_with_one_handler(clean_registry, tmp_path):
    a = str(tmp_path / "a" / "resources")
    b = str(tmp_path / "b" / "resources")
    for resources in (a, b, a, a):
        assert fmu_teardown.release_at_exit(resources, "HumanBody3DOF")
    assert fmu_teardown.registered_binaries() == [
        fmu_teardown.binary_path(a, "HumanBody3DOF"),
        fmu_teardown.binary_path(b, "HumanBody3DOF"),
    ]
    assert clean_registry == [fmu_teardown.release_python_states]


@linux
def test_binaries_not_loaded_are_skipped_and_nothing_is_loaded(clean_registry, tmp_path):
    """A registered path this process has not loaded (here: a file that is not even a
    library) is looked up with RTLD_NOLOAD and skipped."""
    binary = tmp_path / "fmu" / "binaries" / "linux64" / "X.so"
    binary.parent.mkdir(parents=True)
    binary.write_bytes(b"not a shared library")
    fmu_teardown.release_at_exit(str(tmp_path / "fmu" / "resources"), "X")
    assert fmu_teardown.release_python_states() == 0


@linux
def test_does_nothing_off_the_main_thread(clean_registry, monkeypatch):
    """In a non-Python host pythonfmu finalizes Python from its own thread: hands off."""
    calls = []
    monkeypatch.setattr(fmu_teardown, "registered_binaries", lambda: calls.append(1) or [])
    out = []
    worker = threading.Thread(target=lambda: out.append(fmu_teardown.release_python_states()))
    worker.start()
    worker.join()
    assert out == [0] and calls == []
    assert threading.get_native_id() == os.getpid()  # pytest runs tests on the main thread
    assert fmu_teardown.release_python_states() == 0 and calls == [1]


def test_other_platforms_register_nothing(clean_registry, monkeypatch):
    monkeypatch.setattr(sys, "platform", "win32")
    assert fmu_teardown.binary_path("C:/fmu/resources", "HumanBody3DOF") is None
    assert not fmu_teardown.release_at_exit("C:/fmu/resources", "HumanBody3DOF")
    assert fmu_teardown.registered_binaries() == [] and clean_registry == []
