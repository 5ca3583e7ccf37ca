"""Parameter files: loading, validation errors, round trip (bodyvib.models)."""

import copy
import json
import os

import pytest

from bodyvib.models import available_models, load_model, save_model
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.modelfile import network_from_dict, network_to_dict


def reduced_dict():
    return network_to_dict(load_model("reduced-paper"))


def test_shipped_models_load_by_name():
    assert {"reduced-paper", "iso7962"} <= set(available_models())
    red = load_model("reduced-paper")
    assert red.parameters == {
        "m1": 4.88,
        "m2": 65.0,
        "k1": 6.18e4,
        "k2": 6.41e4,
        "ks": 8e5,
        "c1": 333.0,
        "c2": 2935.0,
    }
    iso = load_model("iso7962")
    assert iso.node_names == ("y1", "y2", "y3", "y4")
    assert "Fig. 1.7" in iso.provenance["topology"]  # sourced: the handbook figure


def test_round_trip_through_file(tmp_path):
    net = load_model("iso7962")
    path = tmp_path / "copy.json"
    save_model(net, path)
    again = load_model(str(path))
    assert again == net
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".tmp")]


def test_units_are_kept_through_files_and_mounting(tmp_path):
    """The units field is validated and travels with the model (it is not dropped)."""
    from bodyvib.runtime.network import mount
    from bodyvib.vehicle.quarter_car import load_car

    d = reduced_dict()
    assert d["units"]["k1"] == "N/m"  # network_to_dict writes it
    d["units"] = {"m1": "kg", "c1": "N s/m"}  # any strings, as the file says
    net = network_from_dict(d)
    save_model(net, tmp_path / "u.json")
    assert load_model(tmp_path / "u.json").units == {"m1": "kg", "c1": "N s/m"}
    seated = mount(load_car(), net, at="seat")
    assert seated.units["ms"] == "kg" and seated.units["body.c1"] == "N s/m"
    with pytest.raises(BodyvibError, match="'units' must map parameter names to unit strings"):
        network_from_dict(dict(d, units={"m1": 1}))


def mutate(fn):
    d = reduced_dict()
    fn(d)
    return d


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d["parameters"].update(m1=-4.88), "parameters.m1 = -4.88 must be positive"),
        (lambda d: d["parameters"].update(m2=0), "parameters.m2 = 0 must be positive"),
        (lambda d: d["parameters"].update(k1="stiff"), "parameters.k1: expected a number"),
        (lambda d: d["parameters"].update(c1=float("nan")), "parameters.c1: must be finite"),
        (lambda d: d.pop("masses"), "missing field(s) masses"),
        (lambda d: d.update(colour="red"), "unknown field(s) colour"),
        (lambda d: d["elements"][2].update(to="m9"), "connects unknown point 'm9'"),
        (lambda d: d["elements"][1].update(k="k7"), "unknown parameter 'k7'"),
        (lambda d: d["elements"][1].pop("c"), "a kelvin needs field(s) c"),
        (lambda d: d["elements"][0].update(c="c1"), "unknown field(s) c for a spring"),
        (lambda d: d["elements"][0].update(kind="rubber"), "unknown kind 'rubber'"),
        (
            lambda d: (d["masses"].update(m3="m1"), d["parameters"].update()),
            "m3 not connected to the seat",
        ),
        (lambda d: d["parameters"].update(k9=1.0), "parameter(s) k9 not used"),
        (lambda d: d["roles"].update(head="m7"), "roles.head names unknown point 'm7'"),
        # wrong JSON types: a clear message, not a TypeError from hashing a list
        (
            lambda d: d["elements"][0].update(name=["neck"]),
            "elements[0].name: expected a non-empty string",
        ),
        (
            lambda d: d["elements"][0].update(kind=["spring"]),
            "elements[0].kind: expected a non-empty string",
        ),
        (
            lambda d: d["elements"][0].update(to={"m": 1}),
            "elements[0].to: expected a non-empty string",
        ),
        (lambda d: d["roles"].update(head=["m1"]), "roles.head names unknown point"),
        (lambda d: d.update(force_inputs=[["m1"]]), "'force_inputs' must list mass names"),
    ],
)
def test_invalid_files_name_the_field(change, message):
    with pytest.raises(BodyvibError) as exc:
        network_from_dict(mutate(change), source="bad.json")
    assert message in str(exc.value)
    assert str(exc.value).startswith("bad.json")


def test_unreadable_and_malformed_files(tmp_path):
    with pytest.raises(BodyvibError, match="does not exist"):
        load_model(str(tmp_path / "none.json"))
    bad = tmp_path / "bad.json"
    bad.write_text('{"name": 1,,}')
    with pytest.raises(BodyvibError, match="not valid JSON .line 1"):
        load_model(str(bad))
    with pytest.raises(BodyvibError, match="unknown model 'nope'.*iso7962"):
        load_model("nope")
    binary = tmp_path / "model.bin"
    binary.write_bytes(b"\x7fELF\x02\x01\x01\x00\xd0\xff")  # e.g. an FMU or a program
    with pytest.raises(BodyvibError, match="not a text .UTF-8. JSON model file"):
        load_model(str(binary))


def test_with_parameters_rejects_unknown_names():
    net = load_model("reduced-paper")
    assert net.with_parameters(m1=5.0).parameters["m1"] == 5.0
    assert net.parameters["m1"] == 4.88
    with pytest.raises(BodyvibError, match="no parameter.*mass"):
        net.with_parameters(mass=5.0)


def test_shipped_files_are_plain_json():
    from bodyvib.models import MODEL_DIR

    for name in available_models():
        with open(os.path.join(MODEL_DIR, name + ".json")) as f:
            data = json.load(f)
        network_from_dict(copy.deepcopy(data), source=name)


def test_atomic_write_gives_ordinary_file_mode(tmp_path):
    """Files written atomically get the mode open() would give (umask applied), not 0600."""
    from bodyvib.process.outputs import atomic_write_text

    umask = os.umask(0o022)
    try:
        atomic_write_text(tmp_path / "a.txt", "x")
    finally:
        os.umask(umask)
    assert (os.stat(tmp_path / "a.txt").st_mode & 0o777) == 0o644
    assert (tmp_path / "a.txt").read_text() == "x"


def test_atomic_write_error_names_the_destination(tmp_path):
    """A failed write names the destination, not the hidden temporary file ('.tmp-...')."""
    from bodyvib.process.outputs import atomic_write_text

    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        if os.access(folder, os.W_OK):  # root writes anywhere
            pytest.skip("running as root")
        with pytest.raises(PermissionError) as exc:
            atomic_write_text(folder / "x.txt", "x")
    finally:
        folder.chmod(0o700)
    assert exc.value.filename == str(folder / "x.txt")
    assert not [p for p in os.listdir(folder) if p.startswith(".tmp-")]


_NAMES = [
    "m1",
    "k_seat",
    "_c2",
    "K1s",
    "m 1",
    "1m",
    "k-1",
    "k\n1",
    "k.1",
    "k[1]",
    "'k1'",
    "",
    "k\t",
    "m\u00e9",
]


def _fmpy_accepts(name):
    """fmpy's own check of a variable name under the FMUs' "structured" convention."""
    from fmpy.model_description import ModelDescription, ScalarVariable
    from fmpy.validation import _validate_variable_names

    md = ModelDescription()
    md.variableNamingConvention = "structured"
    md.modelVariables.append(ScalarVariable(name=name, valueReference=0))
    return not _validate_variable_names(md)


@pytest.mark.parametrize("name", _NAMES)
def test_parameter_names_are_valid_fmu_variable_names(name):
    """A parameter name becomes an FMU variable name, so the file check refuses what fmpy's
    validation would refuse only in the built FMU. Every accepted name passes fmpy's check,
    every name fmpy refuses is refused at load."""
    data = json.loads(json.dumps(reduced_dict()))
    data["parameters"][name] = data["parameters"].pop("m1")
    data["masses"]["m1"] = name
    if "m1" in data.get("units", {}):
        data["units"][name] = data["units"].pop("m1")
    try:
        network_from_dict(data, source="t.json")
        accepted = True
    except BodyvibError as exc:
        assert "not a valid FMU variable name" in str(exc)
        accepted = False
    if accepted:
        assert _fmpy_accepts(name)
    if not _fmpy_accepts(name):
        assert not accepted


def test_parameter_named_like_an_interface_variable_is_refused():
    from bodyvib.runtime.engine import FmuCore

    data = reduced_dict()
    data["parameters"]["seat_force"] = data["parameters"].pop("m1")
    data["masses"]["m1"] = "seat_force"
    if "m1" in data.get("units", {}):
        data["units"]["seat_force"] = data["units"].pop("m1")
    net = network_from_dict(data, source="t.json")
    with pytest.raises(BodyvibError, match="seat_force are variables of the body FMU"):
        FmuCore("body", net, "X")
