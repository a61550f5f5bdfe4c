"""This checkout's own pytest settings beyond pyproject.toml: the quick set.

``python -m pytest -m quick`` proves an install works in under 30 s on 2 cores: a shipped
scenario's pytest item (its file loaded, compiled, run on pybullet and compared with its golden
snapshot: :data:`QUICK_SCENARIOS`, marked here, as a YAML file carries no pytest mark), a run on
MuJoCo, and the installed ``stackdsl`` command (the tests marked ``quick``, listed in
tests/test_quick.py's docstring, which keeps the set small).
"""

import pytest


@pytest.hookimpl(tryfirst=True)  # before xdist starts its workers
def pytest_configure(config: pytest.Config) -> None:
    """``-m quick`` runs in this one process: two xdist workers would each collect the whole
    suite (about 3,700 items, most of the quick set's time) to run three tests."""
    if config.getoption("markexpr", "") == "quick" and config.pluginmanager.hasplugin("xdist"):
        config.option.numprocesses, config.option.dist, config.option.tx = 0, "no", []


#: The scenario items in the quick set, by their path from the project's root.
QUICK_SCENARIOS = ("scenarios/bridge.yaml",)


@pytest.hookimpl(tryfirst=True)  # before -m deselects by mark
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if item.nodeid.split("::", 1)[0] in QUICK_SCENARIOS:
            item.add_marker(pytest.mark.quick)
