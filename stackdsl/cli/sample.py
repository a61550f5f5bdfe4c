"""Which run of a scenario file a one-run command takes (``compile``, ``run``, the drawing and
scene commands): a file with a sweep or random fields is many runs, and ``--sample K`` and
``--cell C`` name one (sample 0 of cell 0 by default, said on stderr).

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..lang.errors import ScenarioError

#: What a command does with the sample it takes, as ``stackdsl VERB: DOING sample K ...; --sample K
#: DOES another`` says it (the drawing commands draw it).
_DOING = {
    "run": ("running", "runs"),
    "compile": ("showing", "shows"),
    "replay": ("replaying", "replays"),
    "view": ("showing", "shows"),
    "export": ("exporting", "exports"),
}


def add_sample_options(p: argparse.ArgumentParser, verb: str) -> None:
    """``--sample`` and ``--cell``: which one of a random file's runs ``verb`` takes."""
    doing = "draw" if verb not in _DOING else verb
    p.add_argument(
        "--sample",
        type=int,
        metavar="K",
        help=f"of a file with a sweep or random fields: {doing} its sample K (default 0; the sample column of samples.csv)",
    )
    p.add_argument("--cell", type=int, metavar="C", help=f"of a sweep's grid: {doing} the sample in cell C (default 0)")


def one_sample(scenario: Any, cell: int | None, sample: int | None, verb: str) -> Any:
    """The scenario ``verb`` (``run``, ``compile``, a drawing or scene command) takes: a file
    with a sweep or random fields is one of many runs, so its sample ``sample`` of grid cell
    ``cell`` (0 and 0 by default), said on stderr with how to take another; a plain file is
    itself.

    Raises:
        ScenarioError: ``--sample`` or ``--cell`` on a plain file, a sample past the most a sweep
            draws (:data:`stackdsl.lang.schema_sweep.MAX_SAMPLES`: one past the file's own, which
            ``sweep --samples`` draws, is run), or a cell past the grid's.
    """
    from ..lang.schema_sweep import MAX_SAMPLES

    template = scenario.template
    if template is None:
        given = "--sample" if sample is not None else "--cell" if cell is not None else ""
        if given:
            raise ScenarioError("this file has no sweep and no random field: it is one run, with no samples", file=given)
        return scenario
    c, k = cell or 0, sample or 0
    if not 0 <= k < MAX_SAMPLES:  # past the file's own samples: one 'sweep --samples' draws
        raise ScenarioError(
            f"a sweep draws samples 0 to {MAX_SAMPLES - 1} at most (this one 0 to {template.samples - 1}), not {k}",
            file="--sample",
        )
    if not 0 <= c < template.cells:
        raise ScenarioError(f"the sweep's grid has cells 0 to {template.cells - 1}, not {c}", file="--cell")
    chosen = scenario if (c, k) == (0, 0) else template.scenario(c, k)
    where = f" of grid cell {c} of {template.cells} ({template.label(c)})"
    doing, does = _DOING.get(verb, ("drawing", "draws"))
    of = (
        f"of {template.samples}"
        if k < template.samples
        else f"(past the file's {template.samples}: as 'sweep --samples {k + 1}' draws it)"
    )
    print(
        f"stackdsl {verb}: {doing} sample {k} {of}{where if template.grid else ''} (the sweep's seed {template.seed}, "
        f"this sample's {chosen.seed}: samples.csv's seed column); "
        f"`stackdsl sweep` runs them all and judges the statistics, --sample K {does} another",
        file=sys.stderr,
        flush=True,
    )
    return chosen


def scenario_of(args: argparse.Namespace, verb: str) -> Any:
    """The scenario ``args.file`` names, read with ``args.seed`` (when the command has one), and
    of a random file the sample ``args.sample`` of cell ``args.cell`` (:func:`one_sample`).

    Raises:
        ScenarioError: a bad file, or a sample or cell it does not have.
    """
    from ..lang.loader import load_scenario

    scenario = load_scenario(args.file, getattr(args, "seed", None))
    return one_sample(scenario, getattr(args, "cell", None), getattr(args, "sample", None), verb)
