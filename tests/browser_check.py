"""Open a stackdsl HTML report in headless Chromium: every image loads, the console stays clean.

Run it on a report (it needs the test extra's playwright and a Chromium on the PATH; on
Debian ``apt-get install -y chromium``)::

    stackdsl check scenarios/ --report /tmp/report
    python tests/browser_check.py /tmp/report/index.html --screenshot docs/images/report.png

It prints what it found and exits 0 when every image loaded and the console showed no
error or warning, 1 otherwise. Playwright drives the system's Chromium (``executable_path``);
it downloads no browser of its own.

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path

#: Chromium's names on the PATH, in the order tried.
CHROMIUM = ("chromium", "chromium-browser", "google-chrome")
#: Flags for a headless Chromium as root on a machine with no network: no sandbox (root), no
#: GPU, and none of the background connections that would fail.
FLAGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def chromium() -> str | None:
    """The path of a Chromium on the PATH, or None."""
    return next((p for p in map(shutil.which, CHROMIUM) if p), None)


@dataclass
class PageCheck:
    """What the browser saw: images (src -> loaded), console messages and page errors."""

    images: dict[str, bool] = field(default_factory=dict)
    console: list[str] = field(default_factory=list)
    failed_requests: list[str] = field(default_factory=list)

    @property
    def broken(self) -> list[str]:
        """The images that did not load."""
        return [src for src, ok in self.images.items() if not ok]

    @property
    def ok(self) -> bool:
        """Every image loaded, no console error or warning, no request failed."""
        return not self.broken and not self.console and not self.failed_requests


def check_page(page: str | Path, screenshot: str | Path | None = None, width: int = 1280, height: int = 900) -> PageCheck:
    """Load ``page`` (an HTML file) in headless Chromium and report what it saw; with
    ``screenshot``, save a PNG of the top ``width`` x ``height`` pixels.

    Raises:
        RuntimeError: no Chromium on the PATH.
        ImportError: playwright is not installed (``pip install -e '.[test]'``).
    """
    from playwright.sync_api import sync_playwright

    executable = chromium()
    if executable is None:
        raise RuntimeError("no Chromium on the PATH (on Debian: apt-get install -y chromium)")
    result = PageCheck()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=executable, args=FLAGS)
        try:
            view = browser.new_page(viewport={"width": width, "height": height})
            view.on("console", lambda m: result.console.append(f"{m.type}: {m.text}") if m.type in ("error", "warning") else None)
            view.on("pageerror", lambda e: result.console.append(f"page error: {e}"))
            view.on("requestfailed", lambda r: result.failed_requests.append(f"{r.url}: {r.failure}"))
            view.goto(Path(page).resolve().as_uri(), wait_until="load")
            for src, ok in view.evaluate(
                "[...document.images].map(i => [i.getAttribute('src'), i.complete && i.naturalWidth > 0])"
            ):
                result.images[src] = bool(ok)
            if screenshot is not None:
                view.screenshot(path=str(screenshot))
        finally:
            browser.close()
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Check a stackdsl HTML report in headless Chromium.")
    parser.add_argument("page", help="the report's index.html")
    parser.add_argument("--screenshot", metavar="OUT.png", help="also save a screenshot of the top of the page")
    parser.add_argument("--size", default="1280x900", metavar="WxH", help="the browser window (default: 1280x900)")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.split("x"))
    result = check_page(args.page, args.screenshot, width, height)
    print(f"{len(result.images)} images, {len(result.broken)} broken; {len(result.console)} console errors or warnings")
    for line in [*(f"broken image: {s}" for s in result.broken), *result.console, *result.failed_requests]:
        print(f"  {line}")
    if args.screenshot:
        print(f"wrote {args.screenshot}")
    return 0 if result.ok else 1


if __name__ == "__main__":
    sys.exit(main())
