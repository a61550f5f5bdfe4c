"""Units in scenario files: the factors stackdsl knows without pint are pint's own."""

import pytest

from stackdsl.lang import units
from stackdsl.lang.units import KNOWN_UNITS, angle, length, pint_factor, speed


@pytest.mark.parametrize("key", sorted(KNOWN_UNITS), ids=lambda k: f"{k[0]}->{k[2]}")
def test_a_known_units_factor_is_pints(key):
    assert pint_factor(*key) == pytest.approx(KNOWN_UNITS[key], rel=1e-12)


def test_other_units_go_to_pint_and_wrong_kinds_are_refused():
    assert length("1 inch") == pytest.approx(0.0254)
    assert speed("36 km/h") == pytest.approx(10.0)
    assert angle("0.5 turn") == pytest.approx(180.0)
    with pytest.raises(ValueError, match="expected a length"):
        length("3 s")
    with pytest.raises(ValueError, match="expected an angle"):
        angle("10 %")


def test_a_file_in_the_known_units_never_loads_pint(monkeypatch):
    """pint's registry takes a third of a second or more to build: a file in mm, s, deg, m/s and
    kg/m^3 reads without it."""

    def refuse() -> None:
        raise AssertionError("pint was loaded")

    monkeypatch.setattr(units, "_registry", refuse)
    assert (length("120 mm"), length("2.5 cm"), angle("30 deg"), speed("40 mm/s")) == pytest.approx((0.12, 0.025, 30.0, 0.04))
    from stackdsl import parse_scenario

    text = (
        "stackdsl: 1\nmaterials: {m: {density: 460 kg/m^3, friction: 0.5}}\nbrick_types: {k: {size: [120 mm, 24 mm, 8 mm], material: m}}\n"
        "structure: {tower: {levels: 3, brick: k, spacing: 96 mm, shift: 2 mm, yaw: 5 deg}}\ntiming: {interval: 0.5 s}\n"
    )
    assert parse_scenario(text).structure is not None


def test_a_closed_bound_takes_its_value_however_it_is_written():
    # '1 g/L' is 0.9999999999999999 kg/m^3 and '100 kg/L' 99999.99999999999 in doubles: "from 1 to 100000" takes both
    from stackdsl.lang.units import density, within

    bounded = within(float, density, 1.0, 100_000.0, "a density from 1 to 100000 kg/m^3")
    check = bounded.__metadata__[-1].func
    assert density("1 g/L") < 1.0 and density("100 kg/L") > 99_999.9  # the rounding this is about
    assert check("1 g/L") == 1.0 and check("100 kg/L") == 100_000.0
    with pytest.raises(ValueError, match="expected a density from 1 to 100000"):
        check("0.999999 kg/m^3")
    with pytest.raises(ValueError, match="expected a density from 1 to 100000"):
        check("100.0001 kg/L")
    above = within(float, density, 1.0, 2.0, "a density above 1", above=True).__metadata__[-1].func
    with pytest.raises(ValueError):
        above("1 g/L")  # an open bound stays open
