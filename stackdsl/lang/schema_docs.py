"""What each key of a scenario file means, with an example, for the JSON Schema (editors show
the description on hover and offer the example on completion).

:data:`DOCS` maps a schema object (``""``: the file's top level; otherwise a model of
:mod:`stackdsl.lang.schema` by its ``$defs`` name, or ``Distribution``/``Distribution.normal``)
to its keys, each with a description and one example that the schema accepts (the tests check
both for every key). A key added to the language gets its entry here.

Source: stackdsl's own (the language table of README.md, docs/design.md).
"""

from __future__ import annotations

from typing import Any

from .schema_marks import MARK_DOCS

#: schema object -> key -> (description, example)
DOCS: dict[str, dict[str, tuple[str, Any]]] = {
    "": {
        "stackdsl": ("The format version of the file: 1. Required, first.", 1),
        "name": ("The scenario's name in reports (at most 200 characters); default: the file's stem.", "small tower"),
        "description": ("Free text: what the scenario shows and why.", "A 4 stack hit at level 3; the stack must hold."),
        "seed": ("Seed of every random draw (placement error, distributions, sweep samples); default 0.", 42),
        "materials": (
            "Materials by name, each a density, a static friction coefficient and a restitution; built in: pine "
            "(460 kg/m^3, 0.5, 0).",
            {"steel": {"density": "7800 kg/m^3", "friction": 0.4}},
        ),
        "brick_types": (
            "Brick types by name, each a size [length, width, height] and a material; built in: kapla (120 x 24 x 8 mm, pine).",
            {"plank": {"size": ["200 mm", "24 mm", "8 mm"], "material": "pine"}},
        ),
        "ground": ("The ground plane z = 0: its material (default pine).", {"material": "steel"}),
        "structure": (
            "What is built: one layout (tower, card_house, bricks, wall, pyramid, dominoes), or a list or a map of "
            "named parts, each one layout. Required.",
            {"tower": {"levels": 3, "bricks_per_layer": 2}},
        ),
        "timing": (
            "When bricks are placed: the interval between placements, the settle time after the last action, the drop "
            "gap and the placement error.",
            {"interval": "1 s", "settle": "2 s"},
        ),
        "impacts": (
            "Projectiles thrown at the structure: each a target, a speed and a time.",
            [{"target": {"level": 3, "side": "+y"}, "speed": "1 m/s", "at": "after level 13"}],
        ),
        "engine": (
            "The physics engine and its settings: backend (pybullet, mujoco), mode (raw, tuned, extension), timestep...",
            {"backend": "pybullet", "mode": "extension"},
        ),
        "stability": (
            "The stability extension's model (report or equilibrium) and its rest thresholds.",
            {"model": "equilibrium"},
        ),
        "collapse_threshold": (
            "How far a structure brick may move from its placed pose (at its farthest corner) before it has collapsed; "
            "default half the thinnest brick side (4 mm for KAPLA).",
            "4 mm",
        ),
        "expect": (
            "What must hold after the run: a collapse level, stands, levels that stay, levels that may fall; a sweep's "
            "statistics.",
            {"stands": True},
        ),
        "allow": ("Checks before simulating to silence: [floating] lets a brick be placed resting on nothing.", ["floating"]),
        "sweep": (
            "Many runs of this scenario: samples draws of its random fields in each cell of a grid of field values.",
            {"samples": 200, "grid": {"timing.placement_error": [0, "2 mm", "4 mm"]}},
        ),
        "search": (
            "Where it breaks, for stackdsl search: the value of one field where the verdict changes (threshold), or draws "
            "of the distributions that break the expectation (counterexample).",
            {"threshold": {"field": "structure.tower.shift", "between": ["20 mm", "30 mm"], "tolerance": "0.1 mm"}},
        ),
    },
    "Search": {
        "threshold": (
            "The value of one field where the verdict changes between two ends, bracketed on each run's signed margin.",
            {"field": "structure.tower.shift", "between": ["20 mm", "30 mm"], "tolerance": "0.1 mm"},
        ),
        "counterexample": (
            "Draws of the distributions drawn once a sample that break the expectation, searched with Optuna on the "
            "signed margin, each shrunk and written as a plain scenario file.",
            {"runs": 200, "find": 1, "shrink": 40},
        ),
    },
    "Threshold": {
        "field": (
            "The field searched, named as a sweep's grid key names it, or one number of a list of numbers.",
            "structure.tower.shift",
        ),
        "between": ("Its two ends, the lower first, in a unit of the field's kind.", ["20 mm", "30 mm"]),
        "tolerance": ("How narrow the answer must be, of the same kind (default a hundredth of the interval).", "0.1 mm"),
        "runs": ("Runs the search may take, both ends included, 3 to 10,000 (default 40).", 40),
    },
    "Counterexample": {
        "runs": ("Runs the search may take before shrinking, 1 to 10,000 (default 200).", 200),
        "find": ("Counterexamples to find before it stops, 1 to 100 (default 1).", 1),
        "shrink": ("Runs shrinking each counterexample may take, 0 to 1000 (default 40).", 40),
    },
    "Material": {
        "density": ("Mass per volume of the material (default 460 kg/m^3, pine).", "460 kg/m^3"),
        "friction": (
            "Friction coefficient between two bodies of this material (default 0.5), for sticking and sliding alike; two materials touch with the geometric mean of theirs.",
            0.5,
        ),
        "restitution": (
            "Bounciness, 0 (none, the default) to 1; each engine takes up to what it simulates faithfully in the "
            "run's mode, measured (0.6 to 0.8), and refuses more.",
            0.0,
        ),
    },
    "BrickType": {
        "size": (
            "[length, width, height] along the brick's own x, y and z; each side 1.5 mm to 10 m.",
            ["120 mm", "24 mm", "8 mm"],
        ),
        "material": ("The material's name (built in: pine; or one of materials).", "pine"),
    },
    "Ground": {"material": ("The ground plane's material (default pine).", "pine")},
    "Structure": {
        "tower": ("A layered tower: levels of parallel bricks, each layer turned from the one below.", {"levels": 13}),
        "card_house": ("A house of cards: V's of two leaning bricks, levels of them.", {"levels": 2, "angle": 20}),
        "bricks": (
            "Bricks one by one, placed in list order: each at a position, with yaw, pitch and roll.",
            [{"at": [0, 0, "4 mm"]}, {"at": [0, 0, "12 mm"], "yaw": 90}],
        ),
    },
    "Tower": {
        "brick": ("The brick type of every brick of the tower (default kapla).", "kapla"),
        "levels": ("How many levels are built, 1 to 1000. Required.", 13),
        "bricks_per_layer": ("Parallel bricks in each layer (default 2: the 4 stack).", 2),
        "spacing": ("Centre-to-centre distance of neighbouring bricks of a layer (default 96 mm).", "96 mm"),
        "turn": ("Degrees each layer is turned from the one below (default 90).", 90),
        "shift": (
            "How far each layer is moved from the one below: a length along x, or [x, y] (default 0).",
            "10 mm",
        ),
        "shifts": (
            "One shift a layer above the first, each from the layer below: a length along x or [x, y].",
            ["5 mm", "5 mm", ["0 mm", "3 mm"]],
        ),
        "origin": ("[x, y] of the tower's centre at level 1 (default [0, 0]).", ["0 mm", "0 mm"]),
        "yaw": ("Degrees level 1 is turned about z (default 0).", 0),
        "yaw_jitter": (
            "Degrees more for each brick: one number for all, or one a brick (default 0).",
            {"uniform": ["-2 deg", "2 deg"], "per": "brick"},
        ),
    },
    "CardHouse": {
        "brick": ("The brick type of every brick (default kapla).", "kapla"),
        "levels": ("V's at the base; each level above has one fewer. Required.", 3),
        "angle": ("Degrees each brick leans from vertical, 0 to 60 (default 20).", 20),
        "spacing": ("Distance between neighbouring peaks (default the V's width + 2 mm).", "90 mm"),
        "origin": ("[x, y] of the house's centre (default [0, 0]).", [0, 0]),
    },
    "BrickPlacement": {
        "id": ("The brick's name in outputs (default b001, b002, ...).", "base"),
        "brick": ("The brick type (default kapla).", "kapla"),
        "at": ("[x, y, z] of the brick's centre; a KAPLA brick on the ground is at z = 4 mm. Required.", [0, "48 mm", "4 mm"]),
        "yaw": ("Degrees about z: positive turns +x towards +y (default 0).", 90),
        "pitch": ("Degrees about the brick's new y: positive tips the +x end down (default 0).", 0),
        "roll": ("Degrees about the brick's new x: positive lifts the +y side (default 0).", 0),
        "level": ("The brick's level; default: the rank of its bottom height among the bricks.", 2),
        "fixed": ("An immovable body there from the start (a wall, a ramp), not part of the structure.", False),
        "together": ("Placed at the same moment as the brick before it (the two bricks of a V).", False),
    },
    "Timing": {
        "interval": ("Time between two placements (default 1 s).", "1 s"),
        "settle": ("Time the run goes on after the last action, or after a collapse (default 2 s).", "2 s"),
        "drop_gap": (
            (
                "Bricks are placed at rest this far above their pose and lowered onto it (default 0.5 mm); below the "
                "collapse threshold (by default half the thinnest brick side: 4 mm for KAPLA), and at most 50 mm."
            ),
            "0.5 mm",
        ),
        "placement_error": (
            "Each brick's horizontal offset from its pose, drawn uniformly within +-e on each axis, at most 10 mm (default 0).",
            "1 mm",
        ),
    },
    "Impact": {
        "id": ("The projectile's name in outputs (default impact1, impact2, ...).", "hammer"),
        "projectile": ("The thrown brick's type (default kapla).", "kapla"),
        "target": (
            "What it is thrown at: {level, side} (the middle of that level's outer face on that side) or {point: [x, y, z]}.",
            {"level": 3, "side": "+y"},
        ),
        "speed": ("Speed of the throw, 0.1 to 100 m/s. Required.", "1 m/s"),
        "direction": ("[x, y, z] of the throw (any length); default: into the target's side.", [0, -1, 0]),
        "at": ("When it is thrown: a time, 'after level N' or {after_level: N}. Required.", "after level 13"),
        "distance": ("How far from the target the projectile starts (default 50 mm).", "50 mm"),
    },
    "Target": {
        "level": ("The level whose outer face is hit (with side).", 3),
        "side": ("Which outer face of the level: +x, -x, +y or -y (with level).", "+y"),
        "point": ("A point hit instead, [x, y, z] (needs the impact's direction).", ["0 mm", "60 mm", "101 mm"]),
    },
    "AfterLevel": {"after_level": ("One interval after the last brick of this level is placed.", 13)},
    "AfterPrevious": {
        "after": (
            "One interval after the action written before this one ends ('after the previous action').",
            "the previous action",
        )
    },
    "Engine": {
        "backend": ("The physics engine: pybullet (default) or mujoco.", "pybullet"),
        "mode": (
            "raw: the engine at its defaults; tuned: its most accurate settings; extension (default): the engine plus "
            "the stack stability extension.",
            "extension",
        ),
        "timestep": ("The physics step, at most 10 ms; default per mode (pybullet raw: 1/240 s).", "1/240 s"),
        "solver_iterations": ("The contact solver's iterations a step; default per mode.", 50),
        "friction_anchors": ("pybullet's friction anchors, true or false; default per mode.", True),
        "maximal_coordinates": ("pybullet's maximal coordinates, true or false; default per mode.", True),
        "ccd": ("Continuous collision detection and substeps for fast bodies; default per mode.", True),
        "sleep_tolerance": ("MuJoCo's own sleeping: the speed under which a body sleeps (MuJoCo only).", 0.0001),
    },
    "Golden": {
        "tolerance": (
            "Tolerances of the golden snapshot's measured fields; each key left out is the project's "
            "([tool.stackdsl.golden.tolerance] in pyproject.toml) or the default.",
            {"position": "2 mm", "angle": 2},
        ),
    },
    "GoldenTolerance": {
        "position": ("How far a standing brick's position or centre of mass above may differ (default 1 mm).", "1 mm"),
        "angle": ("Degrees a standing brick may be turned from its golden (default 0.95 for KAPLA).", 1),
        "mass": ("A share of the mass above a brick by which it may differ (default 0.05: 5%).", 0.05),
        "area": ("A share of a contact area by which it may differ (default 0.05).", 0.05),
        "load_share": ("How far a load share (0 to 1) may differ (default 0.05).", 0.05),
        "margin": ("How far the certificate's margin may differ (default 1 mm).", "1 mm"),
        "friction_share": ("How far the share of friction a stand needs may differ (default 0.05).", 0.05),
        "level": ("Levels by which the first moved brick and the moved levels' ends may differ (default 1).", 1),
    },
    "Stability": {
        "model": ("report: the report's rules; equilibrium: rigid-block equilibrium (default report).", "report"),
        "rest_speed": ("A brick slower than this is at rest (default 5 mm/s).", "5 mm/s"),
        "rest_angular_speed": ("A brick turning slower than this is at rest (default 0.05 rad/s).", "0.05 rad/s"),
        "rest_duration": ("How long a brick must be at rest before it is frozen (default 0.05 s).", "0.05 s"),
    },
    "Expect": {
        "collapse": (
            "The collapse level (the highest level placed when the first brick moved past the collapse threshold), "
            "a whole level with an optional whole tolerance: 9, '9±1' or {level, tolerance}; in a sweep, "
            "{mean: ...} or {quantile: ...}, where a fraction may be given.",
            "9±1",
        ),
        "stands": ("true: no structure brick collapses.", True),
        "stays": (
            "Bricks that must end within the collapse threshold of their place, by level, brick id or part name: "
            "'1-12', 5, 'L05.2', 'left' or a list of them.",
            "1-12",
        ),
        "may_fall": ("Bricks allowed to move, by level, brick id or part name (not checked; may not overlap stays).", 13),
        "p_stands": ("A sweep's bound on P(stands), decided by its 95% interval: '>= 0.9'.", ">= 0.9"),
    },
    "CollapseLevel": {
        "level": ("The expected collapse level, a whole number.", 9),
        "tolerance": ("How many whole levels it may be off (default 0).", 1),
    },
    "CollapseStatistic": {
        "mean": (
            "The mean collapse level over the samples that collapsed, with a tolerance: '7.1 ± 1', or a whole level "
            "alone for ± 0: 7.",
            "7.1 ± 1",
        ),
        "quantile": (
            "A quantile q of the collapse level with a tolerance: {q: 0.5, level: '6 ± 1'}.",
            {"q": 0.5, "level": "6 ± 1"},
        ),
    },
    "Within": {
        "target": ("The expected value.", 7.1),
        "tolerance": ("How far it may be off (default 0).", 1),
    },
    "Quantile": {
        "q": ("The quantile, between 0 and 1 (0.5: the median).", 0.5),
        "level": (
            "The expected level at that quantile, with a tolerance, or alone for ± 0 (it must hold a whole level).",
            "6 ± 1",
        ),
    },
    "Probability": {
        "op": ("The comparison: >=, <=, > or <; or ± for a probability within a tolerance.", ">="),
        "bound": ("The probability bound, 0 to 1 (with ±, the probability).", 0.9),
        "tolerance": ("With ±: how far P(stands) may lie from the probability, 0 to 1.", 0.1),
    },
    "Sweep": {
        "samples": ("Draws in each grid cell, 1 to 100,000 (default 1).", 200),
        "grid": (
            "Field paths, each naming one field (not a whole section, part or action) with a list of its values; the sweep runs their product, samples draws a cell.",
            {"timing.placement_error": [0, "2 mm", "4 mm"]},
        ),
    },
    "Distribution": {
        "uniform": ("A value drawn uniformly between [low, high].", ["-60 mm", "60 mm"]),
        "normal": (
            "A value drawn from a normal distribution {mean, sd}, clipped to [low, high] if clip is given.",
            {"mean": "0 mm", "sd": "2 mm"},
        ),
        "choice": ("One of the listed values, each as likely.", [2, 3, 4]),
        "per": ("Drawn once a sample (default), a layer (a tower's shift) or a brick (a tower's yaw_jitter).", "layer"),
    },
    "Distribution.normal": {
        "mean": ("The normal distribution's mean.", "0 mm"),
        "sd": ("Its standard deviation.", "2 mm"),
        "clip": ("[low, high]: draws outside are clipped to these.", ["-5 mm", "5 mm"]),
    },
    "Action": {
        "remove": (
            "Pull a brick out along an axis at a speed (a hand's grip; Jenga).",
            {"brick": "L05.2", "at": "after level 12"},
        ),
        "push": (
            "A pusher moves at a constant speed into a brick or a point for a distance.",
            {"target": {"brick": "d01"}, "direction": [1, 0, 0], "at": "3 s", "speed": "0.1 m/s", "distance": "20 mm"},
        ),
        "shake": (
            "The ground moves as a sinusoid: amplitude, frequency, direction, duration (a shake table).",
            {"amplitude": "2 mm", "frequency": "3 Hz", "duration": "2 s", "at": "after level 4"},
        ),
    },
    "Push": {"target": ("What is pushed: {brick: ID, offset} or {point: [x, y, z]}.", {"brick": "d01"})},
    "Toppled": {
        "count": ("How many bricks must end tilted past their tipping angle, or all.", 20),
        "tolerance": ("How many more or fewer still pass.", 1),
        "op": ("The comparison: ± for count within its tolerance, or >=, <=, > or < for a bound on the count.", ">="),
    },
}

for _where, _keys in MARK_DOCS.items():  # the marks' own docs, beside their models
    DOCS.setdefault(_where, {}).update(_keys)


def documented(schema: dict[str, Any]) -> dict[str, Any]:
    """``schema`` (the scenario JSON Schema, changed in place and returned) with each key of
    :data:`DOCS` described and given its example: the description first, then the kind of value
    the key already says (``a length: a number of metres ...``)."""
    objects = {"": schema, **schema.get("$defs", {})}
    if "Distribution" in objects:
        objects["Distribution.normal"] = objects["Distribution"]["properties"]["normal"]
    for where, keys in DOCS.items():
        properties = objects.get(where, {}).get("properties", {})
        for key, (description, example) in keys.items():
            node = properties.get(key)
            if node is None:
                continue
            kind = node.get("description")
            said = not kind or kind.lower().rstrip(".") in description.lower()
            node["description"] = description if said else f"{description} {_sentence(kind)}"
            node["examples"] = [example]
    return schema


def _sentence(text: str) -> str:
    return text[:1].upper() + text[1:] + ("" if text.endswith(".") else ".")
