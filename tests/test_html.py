"""HTML summaries for Jupyter (lsc.html): every metric's value is shown, names from the scene
are escaped, warnings and sweep failures are shown."""

import re
from html import unescape
from html.parser import HTMLParser

import numpy as np
import pytest

import lsc
from lsc import data
from lsc.html import result_html, summary_html, sweep_html
from lsc.result import METRICS


class _Cells(HTMLParser):
    """The text of every table cell (th, td), and the tags seen."""

    def __init__(self):
        super().__init__()
        self.cells, self.tags, self._in = [], [], False

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        if tag in ("td", "th"):
            self._in = True
            self.cells.append("")

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self._in = False

    def handle_data(self, d):
        if self._in:
            self.cells[-1] += d


def parse(html):
    p = _Cells()
    p.feed(html)
    return p


def hostile():
    """A scene whose names are markup."""
    return {"name": "<i>case</i> & co", "units": "US", "g": "32.2 ft/s^2",
            "vehicles": [{"name": "<b>&", "weight": 3500, "speed": 10},
                         {"name": "<script>x</script>", "weight": 3500, "speed": 0}],
            "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}]}


def test_result_html_shows_every_metric_value():
    r = lsc.solve(data.load("table3"))
    html = result_html(r)
    cells = parse(html).cells
    for name, (_, per) in METRICS.items():
        for x in np.atleast_1d(getattr(r, name)):
            shown = format(float(x), ".6g")
            if per == "scene":
                assert f"{name} {shown} {r.units[name]}" in html
            else:
                assert shown in cells, (name, shown)
    # the paper's Table 3 row at 5 ft/s: 5009 lb (exact: v0 √(kμ) = 5008.35 lb), ΔV2 4.5 ft/s
    assert "5008.35" in cells and "4.5" in cells
    assert ["bullet", "5"] == cells[cells.index("bullet"):][:2]  # v0 beside the name


def test_result_html_escapes_every_name():
    html = result_html(lsc.solve(hostile()))
    assert "&lt;b&gt;&amp;" in html and "&lt;script&gt;x&lt;/script&gt;" in html
    assert "&lt;i&gt;case&lt;/i&gt; &amp; co" in html
    page = parse(html)
    assert not set(page.tags) & {"script", "i"} and page.tags.count("b") == 1  # the scene's name
    assert "<b>&" in page.cells and "<script>x</script>" in page.cells  # shown as text


def test_result_html_lists_the_results_warnings():
    r = lsc.solve(data.load("default"))
    r.stats["warnings"] = ["step 0.001 s > 1/100 of the contact time <0.1 s>"]
    html = result_html(r)
    assert "<li>step 0.001 s &gt; 1/100 of the contact time &lt;0.1 s&gt;</li>" in html


def test_sweep_html_shows_ranges_and_failures():
    s = lsc.sweep(hostile(), {"vehicles.0.speed": [4.0, 6.0, -2.0]})
    html = sweep_html(s)
    cells = parse(html).cells
    ok = s.ok
    for j, label in enumerate(("&lt;b&gt;&amp;", "&lt;script&gt;x&lt;/script&gt;")):
        lo, hi = np.min(s.delta_v[ok, j]), np.max(s.delta_v[ok, j])
        row = html.index(f"<td>delta_v[{label}]</td>")
        assert html[row:].startswith(f"<td>delta_v[{label}]</td><td>{lo:.6g}</td><td>{hi:.6g}</td>")
    assert re.search(r"3 members .*2 solved, 1 failed", html)
    assert "member 2: SceneError: vehicles[0].speed: the vehicles are not closing" in html
    assert "-2" in cells and "6" in cells  # the swept range includes the failed member
    assert "<script>" not in html and "script" not in parse(html).tags


def test_an_analysis_result_is_shown_as_its_own_summary_escaped():
    from lsc.analysis import max_closing_speed

    bound = max_closing_speed(hostile(), "5000 lbf")
    html = summary_html(bound)
    pre = re.search(r"<pre>(.*)</pre>", html, re.DOTALL).group(1)
    assert unescape(pre) == bound.summary()
    assert "<script>" not in html and "&lt;b&gt;&amp;" in html


def test_jupyter_shows_sweeps_and_analyses_through_lsc_html():
    """``_repr_html_`` of a SweepResult and of each analysis result is lsc.html's table; the
    sweep's ``to_dataframe`` / ``to_xarray`` are lsc.frames'."""
    from lsc.analysis import max_closing_speed, monte_carlo
    from lsc.frames import sweep_frame

    s = lsc.sweep(hostile(), {"vehicles.0.speed": [4.0, 6.0, -2.0]})
    assert s._repr_html_() == sweep_html(s)
    assert s.to_dataframe().equals(sweep_frame(s))
    bound = max_closing_speed(hostile(), "5000 lbf")
    assert bound._repr_html_() == summary_html(bound)
    mc = monte_carlo(hostile(), {"vehicles.0.speed": {"uniform": [4.0, 8.0]}}, 20, seed=1,
                     progress=False)
    assert mc._repr_html_() == summary_html(mc)
