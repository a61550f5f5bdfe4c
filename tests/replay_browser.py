"""Open a stackdsl replay page (``stackdsl replay FILE -o DIR``) in headless Chromium with WebGL.

Chromium draws WebGL without a GPU through SwiftShader (``--use-angle=swiftshader``); the
test extra's playwright drives Debian's ``chromium`` (``executable_path``; it downloads no
browser). ``tests/test_replay.py`` uses :func:`open_replay`; run alone, this measures how long
a page takes to load, from navigation to the page's ``window.stackdslReplay.ready``::

    stackdsl replay scenarios/slant_tower.yaml -o /tmp/replay
    python tests/replay_browser.py /tmp/replay/replay.html --repeat 3

and ``python tests/replay_load.py`` measures it on a 400-brick, 60 s run.

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).parent))
from browser_check import FLAGS, chromium

#: WebGL on the CPU: ANGLE over SwiftShader (--disable-gpu of FLAGS would turn WebGL off).
WEBGL_FLAGS = [f for f in FLAGS if f != "--disable-gpu"] + [
    "--use-gl=angle",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]


def missing() -> str:
    """Why the browser tests cannot run here ('' when they can)."""
    if chromium() is None:
        return "Chromium is not installed: apt-get install -y chromium (Debian), then python -m pytest tests/test_replay.py"
    if importlib.util.find_spec("playwright") is None:
        return "playwright is not installed (pip install -e '.[test]')"
    return ""


@dataclass
class Opened:
    """A replay page open in the browser: the playwright page, the console's errors and warnings,
    and the wall seconds from navigation to ready."""

    page: Any
    console: list[str] = field(default_factory=list)
    seconds: float = 0.0

    def call(self, expression: str, *args: Any) -> Any:
        """``window.stackdslReplay.<expression>`` evaluated in the page, with ``args``."""
        if args:
            return self.page.evaluate(f"(a) => window.stackdslReplay.{expression}(...a)", list(args))
        return self.page.evaluate(f"() => window.stackdslReplay.{expression}")


@contextmanager
def browser() -> Iterator[Any]:
    """A headless Chromium with WebGL on SwiftShader (playwright's Browser)."""
    from playwright.sync_api import sync_playwright

    executable = chromium()
    if executable is None:
        raise RuntimeError(missing())
    with sync_playwright() as p:
        launched = p.chromium.launch(executable_path=executable, args=WEBGL_FLAGS)
        try:
            yield launched
        finally:
            launched.close()


def open_replay(launched: Any, page: str | Path, width: int = 1280, height: int = 800, timeout: float = 60.0) -> Opened:
    """Open ``page`` in a new tab of ``launched`` and wait until the replay is ready.

    Raises:
        RuntimeError: the page reported an error instead (its ``window.stackdslReplay.error``).
    """
    tab = launched.new_page(viewport={"width": width, "height": height})
    opened = Opened(tab)
    tab.on("console", lambda m: opened.console.append(f"{m.type}: {m.text}") if m.type in ("error", "warning") else None)
    tab.on("pageerror", lambda e: opened.console.append(f"page error: {e}"))
    tab.on("requestfailed", lambda r: opened.console.append(f"request failed: {r.url}"))
    start = time.perf_counter()
    tab.goto(Path(page).resolve().as_uri(), wait_until="load")
    tab.wait_for_function(
        "window.stackdslReplay && (window.stackdslReplay.ready || window.stackdslReplay.error)", timeout=timeout * 1000
    )
    opened.seconds = time.perf_counter() - start
    error = tab.evaluate("window.stackdslReplay.error")
    if error:
        raise RuntimeError(f"the replay did not start: {error}")
    return opened


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Time how long a stackdsl replay page takes to load in headless Chromium.")
    parser.add_argument("page", help="a replay.html")
    parser.add_argument("--repeat", type=int, default=3, help="loads, each in a new tab (default: 3)")
    args = parser.parse_args(argv)
    with browser() as launched:
        for k in range(args.repeat):
            opened = open_replay(launched, args.page)
            ms = opened.call("loadMs")
            print(
                f"load {k + 1}: {opened.seconds:.2f} s wall to ready ({ms:.0f} ms by the page's clock); console: {len(opened.console)} lines"
            )
            opened.page.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
