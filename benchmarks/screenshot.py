"""Screenshot the first screen of a report page in a real headless browser.

``python -m benchmarks.screenshot REPORT/index.html --out first-screen.png`` runs Chromium
(or Chrome) headless at 1400 x 1000 px (a desktop's first screen), saves what it shows
without scrolling and prints where the page's key parts landed (:func:`first_screen`):
the headline, the settings with their units, the tables beside the figure (MPC against
the best baseline; a single run's metrics) and the top of the figure (the position and
heading dot chart; a single run's figure) must all be in it. No Python
package beyond the standard library; the browser is found on ``PATH`` (``chromium``,
``chromium-browser``, ``google-chrome``...) or given with ``--browser``.
"""

from __future__ import annotations

import argparse
import html
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from mpc.errors import ReportError

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")
WINDOW = (1400, 1000)  # [px] width, height of the first screen
TIMEOUT = 60.0  # [s]
#: The parts of a report's first screen, by CSS selector.
FIRST_SCREEN = {"headline": "p.lead", "settings with units": "p.terms",
                "tables": "div.first div.side", "figure": "div.first img"}
#: Parts that must be whole on the first screen (of the others, the top must be on it).
WHOLE = ("headline", "settings with units", "tables")
_PROBE = """<script>
window.addEventListener("load", function () {
  var parts = %s, out = {};
  Object.keys(parts).forEach(function (name) {
    var element = document.querySelector(parts[name]);
    if (element) { var box = element.getBoundingClientRect(); out[name] = [box.top, box.bottom]; }
  });
  var pre = document.createElement("pre");
  pre.id = "mpc-probe"; pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


def find_browser() -> str | None:
    """The path of the first Chromium-like browser on ``PATH``, None if there is none."""
    for name in BROWSERS:
        found = shutil.which(name)
        if found:
            return found
    return None


def _browser(browser: str | None) -> str:
    binary = browser or find_browser()
    if binary is None:
        raise ReportError(f"no headless browser found (looked for {', '.join(BROWSERS)} on "
                          "PATH); install Chromium or pass --browser")
    return binary


def _run(binary: str, arguments: list[str], timeout: float) -> subprocess.CompletedProcess[str]:
    """The browser, headless, on a throwaway profile, with ``arguments`` last."""
    with tempfile.TemporaryDirectory(prefix="mpc-screenshot-") as profile:
        command = [binary, "--headless", "--no-sandbox", "--disable-gpu",
                   "--disable-background-networking", "--disable-component-update",
                   "--disable-sync", "--no-first-run", "--hide-scrollbars",
                   f"--user-data-dir={profile}", *arguments]
        try:
            return subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                                  check=False)
        except (OSError, subprocess.TimeoutExpired) as error:
            raise ReportError(f"browser {binary} failed: {error}") from error


def first_screen(page: str | Path, browser: str | None = None,
                 window: tuple[int, int] = WINDOW, timeout: float = TIMEOUT
                 ) -> dict[str, tuple[float, float]]:
    """Where the parts of :data:`FIRST_SCREEN` land on ``page`` in a ``window`` [px]:
    ``{part: (top, bottom)}`` [px from the top of the page], parts not found left out. A
    part is on the first screen when its bottom is at most ``window[1]``.

    The browser lays out a copy of the page (with a script that measures the parts) in a
    temporary folder; the report folder is not written to.

    Raises:
        ReportError: the page is missing, no browser is found, or it reports nothing.
    """
    source = Path(page).resolve()
    if not source.is_file():
        raise ReportError(f"page {source} not found")
    binary = _browser(browser)
    text = source.read_text(encoding="utf-8")
    base = f'<base href="{html.escape(source.parent.as_uri())}/">'
    text = re.sub(r"<head>", "<head>" + base, text, count=1)
    text = text.replace("</body>", _PROBE % json.dumps(FIRST_SCREEN) + "</body>")
    with tempfile.TemporaryDirectory(prefix="mpc-probe-") as folder:
        probe = Path(folder) / "probe.html"
        probe.write_text(text, encoding="utf-8")
        done = _run(binary, [f"--window-size={window[0]},{window[1]}",
                             "--virtual-time-budget=5000", "--dump-dom", probe.as_uri()],
                    timeout)
    found = re.search(r'<pre id="mpc-probe">(.*?)</pre>', done.stdout, flags=re.S)
    if found is None:
        raise ReportError(f"browser {binary} measured nothing on {source} (exit "
                          f"{done.returncode})")
    measured = json.loads(html.unescape(found.group(1)))
    return {name: (float(top), float(bottom)) for name, (top, bottom) in measured.items()}


def off_first_screen(parts: dict[str, tuple[float, float]], height: float = WINDOW[1]
                     ) -> list[str]:
    """The parts of :data:`FIRST_SCREEN` not (enough) on a first screen ``height`` [px]
    high: missing, or of :data:`WHOLE` ending below it, or of the others starting below."""
    off = []
    for name in FIRST_SCREEN:
        if name not in parts:
            off.append(name)
            continue
        top, bottom = parts[name]
        if (bottom if name in WHOLE else top) > height:
            off.append(name)
    return off


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
    binary = _browser(browser)
    target = Path(out).resolve()
    target.unlink(missing_ok=True)
    done = _run(binary, [f"--screenshot={target}", f"--window-size={window[0]},{window[1]}",
                         source.as_uri()], timeout)
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
        parts = first_screen(args.page, args.browser)
    except ReportError as error:
        print(f"screenshot: {error}", file=sys.stderr)
        return 1
    missing = off_first_screen(parts)
    for name in FIRST_SCREEN:
        top, bottom = parts.get(name, (float("nan"), float("nan")))
        print(f"{name:20s} {top:6.0f} to {bottom:6.0f} px  "
              f"{'NOT' if name in missing else 'in'} the first screen")
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
