"""Mobility analysis (:mod:`mpc.robots.description.mobility`): Campion's classic answers, robots,
the omnidirectional rule, and strict validation."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from mpc.errors import RobotError
from mpc.robots import (
    PRESETS,
    Mobility,
    mobility,
    preset,
    require_omnidirectional,
    robot_description,
    robot_mobility,
)


def wheel(kind: str, x: float, y: float, **keys: float) -> dict[str, Any]:
    return {"type": kind, "x": x, "y": y, **keys}


def corners(kind: str, **keys: float) -> list[dict[str, Any]]:
    return [wheel(kind, x, y, **keys) for x, y in ((0.3, 0.25), (0.3, -0.25),
                                                   (-0.3, 0.25), (-0.3, -0.25))]


REAR_AXLE = [wheel("fixed", 0.0, 0.25, heading=0.0), wheel("fixed", 0.0, -0.25, heading=0.0)]
TWO_CASTORS = [wheel("caster", -0.3, 0.2, offset=0.03), wheel("caster", -0.3, -0.2, offset=0.03)]

#: The classic table (Campion et al. 1996; Siegwart & Nourbakhsh ch. 3).
CLASSIC: dict[str, tuple[list[dict[str, Any]], tuple[int, int]]] = {
    "differential drive + castor": (
        [*REAR_AXLE, wheel("caster", 0.3, 0.0, offset=0.03)], (2, 0)),
    "car (Ackermann, two steered front wheels)": (
        [*REAR_AXLE, wheel("steered", 0.5, 0.25), wheel("steered", 0.5, -0.25)], (1, 1)),
    "tricycle": ([*REAR_AXLE, wheel("steered", 0.5, 0.0, heading=0.4)], (1, 1)),
    "one steered wheel + castors": ([wheel("steered", 0.3, 0.0), *TWO_CASTORS], (2, 1)),
    "swerve": (corners("steered"), (1, 2)),
    "two-steer (bicycle with both wheels steered)": (
        [wheel("steered", 0.4, 0.0), wheel("steered", -0.4, 0.0)], (1, 2)),
    "axle-offset modules (MPO-700 style)": (corners("axle_offset", lever=0.045), (1, 2)),
    "omni (three Swedish 90 wheels)": (
        [wheel("swedish", 0.2 * math.cos(a), 0.2 * math.sin(a), heading=a + math.pi / 2)
         for a in (math.pi / 2, 7 * math.pi / 6, 11 * math.pi / 6)], (3, 0)),
    "Mecanum": ([wheel("swedish", x, y, heading=0.0, gamma=g) for (x, y), g in
                 zip(((0.15, 0.125), (0.15, -0.125), (-0.15, 0.125), (-0.15, -0.125)),
                     (-math.pi / 4, math.pi / 4, math.pi / 4, -math.pi / 4), strict=True)],
                (3, 0)),
    "powered-caster vehicle": (corners("caster", offset=0.02), (3, 0)),
    "driven balls": ([wheel("spherical", 0.2 * math.cos(a), 0.2 * math.sin(a))
                      for a in (0.0, 2.0, 4.0)], (3, 0)),
    # Axles on x = 0, y = 0 and x + y = 0.6: no common centre of rotation.
    "three fixed wheels, axles not concurrent (immobile)": (
        [wheel("fixed", 0.0, 0.25, heading=0.0), wheel("fixed", 0.3, 0.0, heading=math.pi / 2),
         wheel("fixed", 0.3, 0.3, heading=math.pi / 4)], (0, 0)),
    # Rear axle x = 0 and a third axle y = 0.1 meet at (0, 0.1): rotation about it only.
    "three fixed wheels, axles concurrent": (
        [*REAR_AXLE, wheel("fixed", 0.5, 0.1, heading=math.pi / 2)], (1, 0)),
    "two fixed wheels at an angle (turns about one point)": (
        [wheel("fixed", 0.0, 0.25, heading=0.0), wheel("fixed", 0.3, 0.0, heading=math.pi / 2)],
        (1, 0)),
}


@pytest.mark.parametrize("layout", CLASSIC)
def test_classic_answers(layout: str) -> None:
    wheels, expected = CLASSIC[layout]
    result = mobility({"name": layout, "wheels": wheels})
    assert isinstance(result, Mobility)
    assert tuple(result) == expected
    assert result.degree_of_mobility == expected[0]
    assert result.degree_of_steerability == expected[1]
    assert result.manoeuvrability == sum(expected)


@pytest.mark.parametrize("layout", CLASSIC)
@pytest.mark.parametrize("scale", [1e-3, 1e3])
def test_the_answer_does_not_depend_on_units(layout: str, scale: float) -> None:
    """Millimetre-sized or kilometre-sized, the same wheel set has the same degrees."""
    wheels, expected = CLASSIC[layout]
    scaled = [{k: v * scale if k in ("x", "y", "offset", "lever") else v for k, v in w.items()}
              for w in wheels]
    assert tuple(mobility({"wheels": scaled})) == expected


def test_random_wheel_sets_of_one_kind() -> None:
    """Seeded random layouts: steered modules at 2+ distinct points are (1, 2); wheels that
    add no sliding constraint (casters, Swedish, balls) are (3, 0) whatever their number."""
    rng = np.random.default_rng(8)
    for _ in range(30):
        count = int(rng.integers(2, 7))
        points = rng.uniform(-0.5, 0.5, size=(count, 2))
        steered = [wheel("steered", *p, heading=float(rng.uniform(-3, 3))) for p in points]
        assert tuple(mobility({"wheels": steered})) == (1, 2)
        free = [wheel(str(rng.choice(["caster", "swedish", "spherical"])), *p) for p in points]
        for item in free:
            if item["type"] == "caster":
                item["offset"] = 0.02
            if item["type"] == "swedish":
                item["heading"] = float(rng.uniform(-3, 3))
        assert tuple(mobility({"wheels": free})) == (3, 0)


@pytest.mark.parametrize("name", PRESETS)
def test_robot_objects(name: str) -> None:
    robot = preset(name)
    expected = (1, 2) if robot.kind == "swerve" else (3, 0)
    assert tuple(robot_mobility(robot)) == expected
    description = robot_description(robot)
    assert description["name"] == robot.name and len(description["wheels"]) >= 2


def test_swedish_robot_description_gives_each_wheel_its_rolling_direction() -> None:
    """Mecanum wheels roll along the body's x axis (heading 0) under the X-pattern rollers."""
    description = robot_description(preset("mecanum"))
    headings = [w["heading"] for w in description["wheels"]]
    np.testing.assert_allclose(np.cos(headings), 1.0, atol=1e-12)
    np.testing.assert_allclose([abs(w["gamma"]) for w in description["wheels"]], math.pi / 4)


@pytest.mark.parametrize("layout", ["swerve", "one steered wheel + castors", "Mecanum",
                                    "powered-caster vehicle", "driven balls",
                                    "axle-offset modules (MPO-700 style)"])
def test_omnidirectional_descriptions_pass(layout: str) -> None:
    wheels, expected = CLASSIC[layout]
    assert tuple(require_omnidirectional({"wheels": wheels})) == expected


@pytest.mark.parametrize(("layout", "numbers"), [
    ("differential drive + castor", "(2, 0)"),
    ("car (Ackermann, two steered front wheels)", "(1, 1)"),
    ("tricycle", "(1, 1)"),
    ("three fixed wheels, axles not concurrent (immobile)", "(0, 0)"),
    ("three fixed wheels, axles concurrent", "(1, 0)"),
])
def test_low_manoeuvrability_is_refused_in_one_line(layout: str, numbers: str) -> None:
    wheels, _ = CLASSIC[layout]
    with pytest.raises(RobotError) as error:
        require_omnidirectional({"wheels": wheels}, source="robot file 'x.toml'")
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith("robot file 'x.toml': ")
    assert f"(degree of mobility, degree of steerability) = {numbers}" in message
    assert "cannot follow an arbitrary pose trajectory" in message


GOOD = {"type": "fixed", "x": 0.0, "y": 0.25, "heading": 0.0}


@pytest.mark.parametrize(
    ("description", "match"),
    [
        ([GOOD], "expected a table with 'wheels', got list"),
        ({"wheels": [GOOD], "type": "fixed"}, r"unknown key\(s\) \['type'\]"),
        ({"wheels": [GOOD], "name": 5}, "name must be a string"),
        ({"wheels": []}, "wheels must be a non-empty list"),
        ({"wheels": "fixed"}, "wheels must be a non-empty list"),
        ({}, "wheels must be a non-empty list"),
        ({"wheels": [GOOD, 3]}, r"wheels\[1\] must be a table"),
        ({"wheels": [GOOD, {**GOOD, "type": "tank"}]}, r"wheels\[1\]\.type must be one of"),
        ({"wheels": [GOOD, {**GOOD, "type": None}]}, r"wheels\[1\]\.type must be one of"),
        ({"wheels": [{**GOOD, "offset": 0.1}]},
         r"wheels\[0\] \(fixed\): unknown key\(s\) \['offset'\], missing key\(s\) \[\]"),
        ({"wheels": [{"type": "fixed", "x": 0.0, "y": 0.0}]},
         r"wheels\[0\] \(fixed\): unknown key\(s\) \[\], missing key\(s\) \['heading'\]"),
        ({"wheels": [GOOD, {**GOOD, "x": "0.2"}]}, r"wheels\[1\]\.x must be a finite number"),
        ({"wheels": [GOOD, {**GOOD, "y": True}]}, r"wheels\[1\]\.y must be a finite number"),
        ({"wheels": [GOOD, {**GOOD, "heading": math.nan}]},
         r"wheels\[1\]\.heading must be a finite number within \+-1e\+09 \[rad\]"),
        ({"wheels": [GOOD, {**GOOD, "heading": [0.0]}]}, r"wheels\[1\]\.heading must be"),
        ({"wheels": [{"type": "caster", "x": 0.0, "y": 0.0, "offset": 0.0}]},
         r"wheels\[0\]\.offset must be > 0"),
        ({"wheels": [{"type": "caster", "x": 0.0, "y": 0.0, "offset": False}]},
         r"wheels\[0\]\.offset must be a finite number within \+-1000 \[m\] .*got False"),
        ({"wheels": [{"type": "swedish", "x": 0.0, "y": 0.0, "heading": 0.0,
                      "gamma": math.pi / 2}]}, r"wheels\[0\]\.gamma must not be \+-pi/2"),
        ({"wheels": [{"type": "spherical", "x": 0.0, "y": 0.0, "heading": 0.0}]},
         r"wheels\[0\] \(spherical\): unknown key\(s\) \['heading'\]"),
        ({"wheels": [{"type": "axle_offset", "x": 0.0, "y": 0.0}]},
         r"wheels\[0\] \(axle_offset\): .*missing key\(s\) \['lever'\]"),
    ],
)
def test_bad_descriptions_name_the_wheel_and_field(description: object, match: str) -> None:
    with pytest.raises(RobotError, match=match):
        mobility(description)  # type: ignore[arg-type]
