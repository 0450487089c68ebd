"""Screenshot the first screen of a report page in a real headless browser.

``python -m benchmarks.screenshot REPORT/index.html --out first-screen.png`` runs Chromium
(or Chrome) headless at 1280 x 900 px (a laptop's first screen) and saves what it shows
without scrolling: the headline, a path plot and the settings with their units should all
be in it. No Python package beyond the standard library; the browser is found on ``PATH``
(``chromium``, ``chromium-browser``, ``google-chrome``...) or given with ``--browser``.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from mpc.errors import ReportError

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")
WINDOW = (1280, 900)  # [px] width, height of the first screen
TIMEOUT = 60.0  # [s]


def find_browser() -> str | None:
    """The path of the first Chromium-like browser on ``PATH``, None if there is none."""
    for name in BROWSERS:
        found = shutil.which(name)
        if found:
            return found
    return None


def screenshot(page: str | Path, out: str | Path, browser: str | None = None,
               window: tuple[int, int] = WINDOW, timeout: float = TIMEOUT) -> Path:
    """Save the first ``window`` [px] of ``page`` (an HTML file) as the PNG ``out``.

    Raises:
        ReportError: the page is missing, no browser is found, or the browser fails or
            writes no screenshot within ``timeout`` [s].
    """
    source = Path(page).resolve()
    if not source.is_file():
        raise ReportError(f"page {source} not found")
    binary = browser or find_browser()
    if binary is None:
        raise ReportError(f"no headless browser found (looked for {', '.join(BROWSERS)} on "
                          "PATH); install Chromium or pass --browser")
    target = Path(out).resolve()
    target.unlink(missing_ok=True)
    with tempfile.TemporaryDirectory(prefix="mpc-screenshot-") as profile:
        command = [binary, "--headless", "--no-sandbox", "--disable-gpu",
                   "--disable-background-networking", "--disable-component-update",
                   "--disable-sync", "--no-first-run", "--hide-scrollbars",
                   f"--user-data-dir={profile}", f"--screenshot={target}",
                   f"--window-size={window[0]},{window[1]}", source.as_uri()]
        try:
            done = subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                                  check=False)
        except (OSError, subprocess.TimeoutExpired) as error:
            raise ReportError(f"browser {binary} failed: {error}") from error
    if not target.is_file() or target.stat().st_size == 0:
        tail = (done.stderr or done.stdout).strip().splitlines()[-3:]
        raise ReportError(f"browser {binary} wrote no screenshot (exit {done.returncode}): "
                          + " | ".join(tail))
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.screenshot",
                                     description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("page", help="the report's index.html")
    parser.add_argument("--out", default="first-screen.png", help="PNG to write")
    parser.add_argument("--browser", help="Chromium-like browser (default: found on PATH)")
    args = parser.parse_args(argv)
    try:
        print(f"wrote {screenshot(args.page, args.out, args.browser)}")
    except ReportError as error:
        print(f"screenshot: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
