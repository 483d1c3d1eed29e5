"""The paper's numbers in the project (pipeline.published) against their transcriptions in ../shared/reference, so
that a typo in either fails; the user's own tables replace them, and a bad one is refused naming file, line and
field."""

import tomllib

import pytest

from fem.bolts import BOLT_PRELOAD
from fem.elasticity import Material
from geometry.parameters import BRB
from locations import REFERENCE
from pipeline.published import (BRB_DECK, TABLE1, TABLE3, TABLE3_UNITS, TABLE5, TABLE6, TABLE_FILES, paper_tables,
                                read_table1, read_table3, read_table5, read_table6)
from study.errors import DAMPING_TOLERANCE, FREQUENCY_TOLERANCE_HZ


def shared(name: str):
    path = REFERENCE / name
    if not path.is_file():
        pytest.skip(f"the transcribed reference is absent ({path})")
    return path


def test_table1_is_the_transcribed_one():
    assert read_table1(shared(TABLE_FILES["table1"])) == TABLE1


def test_table3_is_the_transcribed_one_with_its_units():
    path = shared(TABLE_FILES["table3"])
    assert read_table3(path) == TABLE3
    units = {line.split(",")[0]: line.strip().split(",")[-1] for line in path.read_text().splitlines()[1:]}
    assert units == TABLE3_UNITS


def test_tables_5_and_6_are_the_transcribed_ones():
    assert read_table5(shared(TABLE_FILES["table5"])) == TABLE5
    assert read_table6(shared(TABLE_FILES["table6"])) == TABLE6


def test_brb_dimensions_are_the_decks():
    deck = tomllib.loads(shared("brb_geometry.toml").read_text())
    for field, value in BRB_DECK.items():
        assert deck["patch_cuts_fraction" if field == "patch_cuts" else field] == pytest.approx(value, abs=0, rel=0)
        assert getattr(BRB, field) == value
    assert deck["half_length"] == pytest.approx(BRB.half_length, rel=1e-12)


def test_the_papers_constants_in_the_code():
    constants = tomllib.loads(shared("paper_constants.toml").read_text())
    assert BOLT_PRELOAD == constants["bolt_preload_N"]
    assert (Material().youngs_modulus, Material().poissons_ratio) == (constants["youngs_modulus_Pa"],
                                                                       constants["poissons_ratio"])
    assert (FREQUENCY_TOLERANCE_HZ, DAMPING_TOLERANCE) == (constants["frequency_tolerance_Hz"],
                                                           constants["damping_tolerance"])
    # the paper rounds the deck's hole and washer diameters to 0.01 mm
    assert BRB.hole_diameter == pytest.approx(constants["hole_diameter_m"], abs=5e-6)
    assert BRB.washer_outer_diameter == pytest.approx(constants["washer_diameter_m"], abs=5e-6)


def test_a_reference_folder_replaces_the_tables_it_holds(tmp_path):
    (tmp_path / TABLE_FILES["table1"]).write_text("beam,frequency_hz,damping_factor\nBRB,170.0,0.002\n")
    tables = paper_tables(tmp_path)
    assert tables.table1 == {"BRB": TABLE1["BRB"].__class__("BRB", 170.0, 0.002)}
    assert (tables.table3, tables.table5, tables.table6) == (TABLE3, TABLE5, TABLE6)
    assert tables.sources == {"table1": str(tmp_path / TABLE_FILES["table1"]), "table3": "paper",
                              "table5": "paper", "table6": "paper"}
    assert paper_tables().sources == dict.fromkeys(TABLE_FILES, "paper")


def test_the_shared_reference_folder_gives_the_papers_tables():
    tables = paper_tables(shared(TABLE_FILES["table1"]).parent)
    assert (tables.table1, tables.table3, tables.table5, tables.table6) == (TABLE1, TABLE3, TABLE5, TABLE6)


@pytest.mark.parametrize("table, text, message", [
    ("table1", "beam,frequency_hz,damping_factor\nBRB,169.48 Hz,0.002\n",
     "line 2, field 'frequency_hz' = '169.48 Hz': expected a frequency in Hz"),
    ("table1", "beam,frequency,damping_factor\nBRB,169.48,0.002\n", "column 'frequency_hz' missing"),
    ("table3", "parameter,minimum,maximum,sampling\nF_S,10,1e11,logarithmic\n",
     "field 'sampling' = 'logarithmic': expected log or linear"),
    ("table5", "model,surrogate,real,confidence\njenkins,BRB,BRB,1.0\n",
     "model jenkins: no row for surrogate BRB, real LBRB"),
])
def test_a_bad_table_is_refused_naming_file_and_field(tmp_path, table, text, message):
    path = tmp_path / TABLE_FILES[table]
    path.write_text(text)
    with pytest.raises(ValueError) as error:
        paper_tables(tmp_path)
    assert str(error.value).startswith(f"{path}: ") and message in str(error.value)


def test_a_missing_reference_folder_is_refused(tmp_path):
    with pytest.raises(ValueError, match="no such folder"):
        paper_tables(tmp_path / "absent")
