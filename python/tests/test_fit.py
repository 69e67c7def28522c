"""spherestep.fit: a scenario fitted to the bench's files, the command line's numbers to the bit,
and its errors naming the file."""

import json

import pytest

import spherestep
from conftest import ROOT, SCENARIOS

FIT = ROOT / "assets" / "fit"


def test_a_physical_scenario_fits_its_core_gain_and_gap_as_the_command_line_does(cli):
    scenario = SCENARIOS / "prototype-physical.toml"
    bench = FIT / "bench-physical.csv"
    got = spherestep.fit(str(scenario), bench)
    assert got["fitted_as"] == "physical"
    values, errors = got["parameters"], got["std_errors"]
    assert set(values) == {"core_gain", "gap_m"} == set(errors)
    # the hidden motor (assets/fit/hidden-physical.toml): gain 5.2, gap 0.00943 m
    assert values["core_gain"] == pytest.approx(5.2, rel=0.03)
    assert values["gap_m"] == pytest.approx(0.00943, rel=0.03)
    assert 0 < errors["core_gain"] < 0.05 * values["core_gain"]
    assert 0 < errors["gap_m"] < 0.05 * values["gap_m"]
    want = json.loads(cli("fit", scenario, "--torque", bench, "--json"))
    assert got["report"] == want
    assert got["rms_nm"] == want["parts"]["rms_nm"]
    # a Scenario object fits alike
    again = spherestep.fit(spherestep.Scenario.load(scenario), torque=bench)
    assert again["parameters"] == values


def test_wells_from_a_curve_and_a_log_with_their_standard_errors(cli):
    args = dict(torque=FIT / "bench.csv", log=FIT / "replay.csv", holdout=10)
    got = spherestep.fit(SCENARIOS / "prototype.toml", **args)
    assert got["fitted_as"] == "wells"
    # the strength from the curve; the width and the reach from the log
    assert list(got["parameters"]) == ["strength_j", "width_deg", "max_attraction_deg"]
    steps = got["report"]["steps"]["estimates"]
    assert got["parameters"]["width_deg"] == steps[0]["value"]
    assert got["std_errors"]["width_deg"] == steps[0]["std_error"]
    want = json.loads(
        cli(
            "fit", SCENARIOS / "prototype.toml", "--torque", args["torque"],
            "--log", args["log"], "--holdout", "10", "--json",
        )
    )
    assert got["report"] == want
    cosine = spherestep.fit(SCENARIOS / "prototype.toml", FIT / "bench.csv", fit_as="cosine")
    assert cosine["report"]["curve"][0]["wells"]["shape"] == "cosine"
    assert list(cosine["parameters"]) == ["strength_j", "max_attraction_deg"]


def test_errors_name_the_file_or_the_argument(tmp_path):
    bad = tmp_path / "bench.csv"
    bad.write_text("angle_deg,torque_nm\n0,0\n1,x\n")
    with pytest.raises(spherestep.Error, match=r"bench\.csv: line 3: column `torque_nm`"):
        spherestep.fit(SCENARIOS / "prototype-physical.toml", bad)
    flat = tmp_path / "flat.csv"
    flat.write_text("angle_deg,torque_nm\n" + "".join(f"{a},0\n" for a in range(8)))
    with pytest.raises(spherestep.Error, match=r"flat\.csv: fitting the wells: the torque curve pulls nowhere"):
        spherestep.fit(SCENARIOS / "prototype-physical.toml", flat)
    with pytest.raises(spherestep.Error, match=r"nowhere\.toml"):
        spherestep.fit(tmp_path / "nowhere.toml", FIT / "bench.csv")
    with pytest.raises(spherestep.Error, match="argument fit_as: expected physical only"):
        spherestep.fit(SCENARIOS / "prototype.toml", FIT / "bench.csv", fit_as="physical")
    with pytest.raises(spherestep.Error, match="argument fit_as: expected one of wells"):
        spherestep.fit(SCENARIOS / "prototype.toml", FIT / "bench.csv", fit_as="dipole")
    with pytest.raises(spherestep.Error, match="argument torque/log"):
        spherestep.fit(SCENARIOS / "prototype.toml")
    with pytest.raises(spherestep.Error, match="argument scenario: expected a Scenario"):
        spherestep.fit(3, FIT / "bench.csv")
