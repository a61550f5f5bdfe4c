"""Optional features and the extra that installs each: MuJoCo, Dask, MP4 clips, the profiler, Parquet.

``pip install stackdsl`` brings pybullet and what every scenario needs; the heavy optional
features are extras (``pip install 'stackdsl[mujoco]'``, ``[dask]``, ``[video]``, ``[profile]``,
``[parquet]``, ``[search]``, ``[all]``).
A feature used without its extra is one line naming the command that adds it, raised where
the feature is asked for (the scenario's field, the command's option) before anything runs.

>>> missing("mujoco")
"MuJoCo is not installed: pip install 'stackdsl[mujoco]' (in a source checkout: pip install -c constraints.txt '.[mujoco]')"

Source: stackdsl's own.
"""

from __future__ import annotations

import importlib.util

#: extra -> (the module it installs, what a person calls it)
EXTRAS = {
    "mujoco": ("mujoco", "MuJoCo"),
    "dask": ("distributed", "Dask's distributed"),
    "video": ("imageio_ffmpeg", "imageio-ffmpeg (the ffmpeg that writes MP4)"),
    "profile": ("pyinstrument", "pyinstrument (a sampling profiler)"),
    "parquet": ("pyarrow", "pyarrow (Parquet files)"),
    "search": ("optuna", "Optuna (a counterexample search's sampler)"),
}


def installed(extra: str) -> bool:
    """Whether the module of ``extra`` (a key of :data:`EXTRAS`) can be imported.

    Raises:
        KeyError: an unknown extra.
    """
    module, _ = EXTRAS[extra]
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a module set to None in sys.modules, a broken parent package
        return False


def missing(extra: str, what: str = "") -> str:
    """The one-line message for ``what`` (the thing asked for, if said) needing ``extra``:
    ``"an MP4 clip needs imageio-ffmpeg (...), which is not installed: pip install 'stackdsl[video]'"``,
    or ``"MuJoCo is not installed: pip install 'stackdsl[mujoco]' (in a source checkout: ...)"``."""
    _, name = EXTRAS[extra]
    needs = f"{what} needs {name}, which is" if what else f"{name} is"
    return f"{needs} not installed: pip install 'stackdsl[{extra}]' (in a source checkout: {checkout(extra)})"


def checkout(extra: str) -> str:
    """The command that adds ``extra`` to an install from a source checkout of stackdsl (the
    README's, run in the checkout's folder): ``pip install -c constraints.txt '.[mujoco]'``."""
    return f"pip install -c constraints.txt '.[{extra}]'"
