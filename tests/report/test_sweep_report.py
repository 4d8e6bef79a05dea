"""The HTML report of a store, checked in a real headless browser (Chromium)."""

from __future__ import annotations

import functools
import http.server
import os
import re
import shutil
import subprocess
import threading

import pytest
from _sweep_helpers import write_sweep

from sampledyn.cli import main
from sampledyn.experiments.sweep import run_sweep

_BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def _browser() -> str:
    for name in _BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    if os.environ.get("CI") or os.environ.get("SAMPLEDYN_REQUIRE_CHROMIUM"):
        pytest.fail("Chromium is required in CI (.ci/run installs it) but was not found.")
    pytest.skip("no Chromium on this machine (apt-get install -y chromium); CI runs this test")


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    d = tmp_path_factory.mktemp("report")
    db = d / "r.db"
    run_sweep(write_sweep(d / "s.toml", h="[0.01, 0.02]"), db)
    # a second, incompatible study in the same store (another norm): reported apart
    run_sweep(write_sweep(d / "t.toml", h="[0.02]", norm='"max"'), db)
    out = d / "site"
    assert main(["report", str(db), "--out", str(out)]) == 0
    return out


def _dump_dom(browser: str, url: str, profile) -> str:
    cmd = [
        browser,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={profile}",
        "--virtual-time-budget=10000",
        "--dump-dom",
        url,
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # no request log on stderr
        pass


def _serve(folder):
    handler = functools.partial(_QuietHandler, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


def _figures(dom: str) -> tuple[int, int, list[int]]:
    body = re.search(r"<body([^>]*)>", dom)
    assert body, dom[:500]
    total = re.search(r'data-figures="(\d+)"', body.group(1))
    loaded = re.search(r'data-figures-loaded="(\d+)"', body.group(1))
    assert total and loaded, f"the page script did not run: {body.group(0)}"
    widths = [int(w) for w in re.findall(r'<img[^>]*data-natural-width="(\d+)"', dom)]
    return int(total.group(1)), int(loaded.group(1)), widths


@pytest.mark.slow  # a headless Chromium process
def test_report_loads_in_a_headless_browser_with_every_figure(report, tmp_path):
    browser = _browser()
    pngs = sorted(p.name for p in (report / "figures").glob("*.png"))
    assert len(pngs) == 4  # 2 studies x (order plot, ratio map)
    server = _serve(report)
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}/index.html"
        dom = _dump_dom(browser, url, tmp_path / "profile")
    finally:
        server.shutdown()
    total, loaded, widths = _figures(dom)
    assert total == loaded == len(pngs)
    assert len(widths) == len(pngs) and min(widths) > 0
    for name in pngs:
        assert f'src="figures/{name}"' in dom
    assert "Fig. 7-style" in dom and "AB1 ~" in dom
    assert dom.count("<h2>Study ") == 2


@pytest.mark.slow  # a headless Chromium process
def test_browser_check_sees_a_missing_figure(report, tmp_path):
    """The same check fails when a figure does not load."""
    browser = _browser()
    broken = tmp_path / "site"
    shutil.copytree(report, broken)
    next((broken / "figures").glob("*ratio.png")).unlink()
    dom = _dump_dom(browser, (broken / "index.html").as_uri(), tmp_path / "profile")
    total, loaded, widths = _figures(dom)
    assert loaded == total - 1 and sorted(widths)[0] == 0


def test_markdown_report_has_the_tables_and_figures(report):
    md = (report / "report.md").read_text()
    assert md.count("![") == 4
    assert "| noise (eta %, v %) |" in md
    for link in re.findall(r"\]\((figures/[^)]+)\)", md):
        assert (report / link).is_file()
