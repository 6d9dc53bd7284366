"""report.html: the report's text as one self-contained page, checked with the standard library's HTML parser
and opened in a headless Chromium (selenium; Debian's chromium and chromium-driver, which CI installs)."""

from __future__ import annotations

import base64
import json
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from pinid.report.html import markdown_to_html
from tests.conftest import load

PNG = b"\x89PNG\r\n\x1a\n" + b"\x00" * 8


class Page(HTMLParser):
    """Collects tags, attributes, table rows and text; fails on unbalanced tags."""

    VOID = {"meta", "img", "br", "hr", "link"}

    def __init__(self, text: str) -> None:
        super().__init__()
        self.stack, self.tags, self.attrs, self.tables, self.text = [], [], [], [], []
        self.feed(text)
        self.close()
        assert not self.stack, f"unclosed tags {self.stack}"

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.attrs.append((tag, dict(attrs)))
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self.tables[-1][-1].append("")
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        assert self.stack and self.stack[-1] == tag, f"</{tag}> closes {self.stack[-1:]}"
        self.stack.pop()

    def handle_data(self, data):
        self.text.append(data)
        if "td" in self.stack or "th" in self.stack:
            self.tables[-1][-1][-1] += data


def external_resources(page: Page) -> list[str]:
    """Every reference to something outside the page (scripts, style sheets, non-data images, links)."""
    bad = [f"<{t}>" for t in page.tags if t in ("script", "link", "iframe", "object", "embed")]
    for tag, attrs in page.attrs:
        for key in ("src", "href"):
            if key in attrs and not attrs[key].startswith("data:"):
                bad.append(f"<{tag} {key}={attrs[key][:40]}>")
    return bad


def test_renderer_subset():
    text = (
        "# Title `x<y>`\n\nA paragraph with **bold** and `code`,\ncontinued.\n\n- one\n- two & three\n\n"
        "| a | b |\n|---|---|\n| 1 | **2** |\n| 3 \\| x | 4 |\n\n![a [p5, p95] figure](fig.png)\n\n```python\nif a < b:\n```\n"
    )
    page = Page(markdown_to_html(text, {"fig.png": PNG}, title="t"))
    assert page.tags.count("h1") == 1 and page.tags.count("li") == 2 and page.tags.count("strong") == 2
    assert page.tables == [[["a", "b"], ["1", "2"], ["3 | x", "4"]]]
    assert "if a < b:" in "".join(page.text) and "x<y>" in "".join(page.text)  # escaped, shown as text
    (img,) = [a for t, a in page.attrs if t == "img"]
    assert img["alt"] == "a [p5, p95] figure" and base64.b64decode(img["src"].split(",", 1)[1]) == PNG
    assert external_resources(page) == []
    with pytest.raises(KeyError, match="missing.png"):
        markdown_to_html("![x](missing.png)", {})


def test_hard_line_breaks_and_prose_cells():
    """Issue 47: a line ending in two spaces (the report's warnings, one per line) breaks the paragraph there, as
    GitHub renders report.md, instead of running the warnings together; a long prose cell wraps (class text)
    while numbers stay on one line."""
    out = markdown_to_html("**w1**  \n**w2**\nmore\n\n| a | b |\n|---|---|\n| 1.5 | " + "name, " * 10 + "|\n")
    assert "<p><strong>w1</strong><br>\n<strong>w2</strong> more</p>" in out
    assert "<td>1.5</td>" in out and '<td class="text">name, name' in out


def test_folded_sections_and_scrolling_tables():
    """The raw HTML lines that fold a section pass through as they are (GitHub renders them in the
    Markdown too); Markdown inside a fold is rendered; every table scrolls in its own block."""
    text = (
        "## Methods\n\n<details open>\n<summary><strong>ols</strong> (best): 1 %</summary>\n\nText **b**.\n\n"
        "| a | b |\n|---|---|\n| 1 | 2 |\n\n</details>\n\n<details>\n<summary>wls</summary>\n\n- x\n\n</details>\n"
    )
    out = markdown_to_html(text)
    page = Page(out)  # balanced: every <details> closed
    assert [a for t, a in page.attrs if t == "details"] == [{"open": None}, {}]
    assert page.tags.count("summary") == 2 and page.tags.count("li") == 1 and page.tables == [[["a", "b"], ["1", "2"]]]
    assert '<div class="table"><table>' in out and out.count("<table>") == out.count('<div class="table">')
    assert ".table { overflow-x: auto;" in out  # wide tables scroll inside the page, the page does not
    assert "&lt;details" not in out and "<p><summary>" not in out


METHODS = ["ols", "wls", "pso"]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """``pinid identify`` on two twin recordings: (output folder, what it printed)."""
    import contextlib
    import io

    from pinid.cli.main import main
    from pinid.data.formats import write_recording
    from pinid.excitation.trajectory import FourierTrajectory
    from pinid.simulation.twin import simulate

    tmp = tmp_path_factory.mktemp("report")
    model = load("exo_leg")
    files = []
    for seed, w in ((0, 0.2), (1, 0.25)):
        traj = FourierTrajectory(
            ["hip", "knee"], w * np.pi, [0.6, -0.9], [[0.25, 0.1], [0.25, -0.1]], [[0.1, 0.05], [-0.1, 0.05]]
        )
        ds, _ = simulate(model, traj, seconds=10.0, seed=seed)
        files.append(write_recording(tmp / f"run{seed}.csv", ds))
    out = tmp / "out"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = main(
            [
                "identify",
                "--data",
                str(files[0]),
                "--validate",
                str(files[1]),
                "--methods",
                ",".join(METHODS),
                "--option",
                "pso.iterations=20",
                "-o",
                str(out),
            ]
        )
    assert status == 0
    return out, printed.getvalue()


@pytest.mark.slow  # 6 s of CPU (docs/benchmarks.md, Test suite)
def test_identify_writes_self_contained_html(report):
    """pinid identify's report.html: summary table first with one row per method, a section per method,
    the excitation and every figure embedded as a data: URI — the same figures as the PNG files."""
    out, printed = report
    methods = METHODS
    assert "== ols" not in printed and "valid. RMS raw [N·m]" in printed  # the summary; the detail is in the report
    assert max(map(len, printed.splitlines())) <= 120
    page = Page((out / "report.html").read_text())
    assert external_resources(page) == []
    for table in page.tables:  # a "|" in a cell (|e|) must not split it
        assert all(len(row) == len(table[0]) for row in table), table
    summary = page.tables[0]
    assert summary[0][0] == "method" and [r[0] for r in summary[1:]] == methods
    md = (out / "report.md").read_text()
    best = json.loads((out / "identification.json").read_text())["best"]
    for m in methods:  # a folded section per method, the best one open
        opening = "<details open>" if m == best else "<details>"
        assert f"{opening}\n<summary><strong>{m}</strong>{' (best)' if m == best else ''}: " in md, m
    assert [a for t, a in page.attrs if t == "details"].count({"open": None}) == 1
    assert page.tags.count("details") == page.tags.count("summary") == len(methods)
    imgs = [a["src"] for t, a in page.attrs if t == "img"]
    assert all(src.startswith("data:image/png;base64,") for src in imgs)
    embedded = {base64.b64decode(src.split(",", 1)[1]) for src in imgs}
    pngs = {p.name: p.read_bytes() for p in out.glob("*.png")}
    figures = {"errors.png", "parameters.png", "predictions.png", "training_motion.png", f"torque_{best}.png"}
    assert set(pngs) == figures  # the comparison's figures and the best method's torque, not one per method
    assert embedded == set(pngs.values())
    assert page.tags.index("table") < page.tags.index("img")  # the summary table comes before any figure
    # the comparison leads: its figures (the parameter plausibility beside the torque error) before the detail
    lead = md.split("## Robot and data")[0]
    assert all(f"]({name})" in lead for name in figures - {"training_motion.png"})
    assert lead.index("](errors.png)") < lead.index("](parameters.png)") < lead.index(f"](torque_{best}.png)")
    # the HTML is the Markdown's text: every heading of report.md is a heading of the page
    for line in md.splitlines():
        if line.startswith("#"):
            assert line.lstrip("# ").replace("`", "") in "".join(page.text), line


#: How a new user gets the browser the test needs (the skip says it).
BROWSER_HINT = (
    "to run it: apt-get install chromium chromium-driver (Debian/Ubuntu; the selenium package comes with "
    "pip install -e '.[test]'), then PINID_BROWSER_TEST=required python -m pytest tests/report/test_report_html.py"
)


def _browser():
    """A headless Chromium driven by selenium, or the reason there is none."""
    import os
    import shutil

    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        return None, f"selenium is not installed; {BROWSER_HINT}"
    binary = next((b for b in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if b), None)
    driver = shutil.which("chromedriver")
    if binary is None or driver is None:
        return None, f"no Chromium with its driver (chromedriver) on PATH; {BROWSER_HINT}"
    opts = webdriver.ChromeOptions()
    opts.binary_location = binary
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1400,900"):
        opts.add_argument(arg)
    try:
        return webdriver.Chrome(service=Service(driver), options=opts), None
    except Exception as exc:  # a browser that does not start is a skip, unless CI installed it on purpose
        if os.environ.get("PINID_BROWSER_TEST") == "required":
            raise
        return None, f"Chromium did not start: {type(exc).__name__}: {str(exc).splitlines()[0]}; {BROWSER_HINT}"


@pytest.fixture(scope="module")
def browser():
    """One headless Chromium for the module's page tests; skipped (failed with PINID_BROWSER_TEST=required)
    without one, the skip saying how to get it."""
    import os

    driver, reason = _browser()
    if driver is None:
        if os.environ.get("PINID_BROWSER_TEST") == "required":
            pytest.fail(reason)
        pytest.skip(reason)
    yield driver
    driver.quit()


def test_skip_says_how_to_get_the_browser(monkeypatch):
    """Issue 47: without Chromium the skip tells a new user the apt-get line and the variable that requires it."""
    import shutil

    monkeypatch.setattr(shutil, "which", lambda name: None)
    monkeypatch.delenv("PINID_BROWSER_TEST", raising=False)
    driver, reason = _browser()
    assert driver is None
    assert "apt-get install chromium chromium-driver" in reason and "PINID_BROWSER_TEST=required" in reason, reason


#: What a person sees, measured in the page: every image decoded and inside the viewport, no horizontal
#: overflow of the page, of a table's block or of a figure (a wider table scrolls in its block only if the
#: window is narrower than the page's column).
LOOK = """
const vw = document.documentElement.clientWidth;
const imgs = Array.from(document.images);
const over = (e) => e.scrollWidth > e.clientWidth + 1;
const name = (e) => (e.querySelector('th') || e.querySelector('img') || e).textContent.slice(0, 40)
  || (e.querySelector('img') || {}).alt;
return {
  images: imgs.length,
  broken: imgs.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.alt),
  outside: imgs.filter(i => i.getBoundingClientRect().right > vw + 1 || i.getBoundingClientRect().width <= 0)
    .map(i => [i.alt, i.getBoundingClientRect().right, vw]),
  page: [document.documentElement.scrollWidth, vw, document.body.scrollWidth, document.body.clientWidth],
  tables: Array.from(document.querySelectorAll('div.table, figure, pre')).filter(over)
    .map(e => [e.tagName, name(e), e.scrollWidth, e.clientWidth]),
  fetched: performance.getEntriesByType('resource').map(e => e.name),
  height: document.documentElement.scrollHeight,
  title: document.title,
};"""


def screenshot_folder(tmp_path_factory) -> Path:
    """Where the screenshots go: $PINID_SCREENSHOTS if set (CI keeps it as an artefact), else a pytest temporary
    folder (printed; ``pytest -s`` shows it)."""
    import os

    folder = Path(os.environ.get("PINID_SCREENSHOTS") or tmp_path_factory.mktemp("screenshots"))
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def look_at(browser, page: Path, shot: Path, width: int = 1400) -> dict:
    """Open ``page`` at ``width`` px, measure it (:data:`LOOK`) and keep a full-page screenshot in ``shot``."""
    browser.set_window_size(width, 900)
    browser.get(page.as_uri())
    state = browser.execute_script(LOOK)
    browser.set_window_size(width, min(state["height"] + 200, 30_000))  # the whole page in one picture
    browser.save_screenshot(str(shot))
    print(f"screenshot of {page.name}: {shot}")
    return state


def assert_looks_right(state: dict, images: int) -> None:
    assert state["images"] == images and state["broken"] == [], state
    assert state["outside"] == [] and state["tables"] == [], state
    assert state["page"][0] <= state["page"][1] and state["page"][2] <= state["page"][3], state["page"]
    assert state["fetched"] == [], state["fetched"]


@pytest.mark.slow  # 4.4 s with its report (Chromium): the README's full command, CI's browser stage, runs it
def test_report_opens_in_a_headless_browser(report, browser, tmp_path_factory):
    """A real browser (headless Chromium through selenium) opens report.html from disk: every image decodes and
    fits, nothing overflows sideways, nothing is fetched (no resource entries at all), the summary table has one
    row per method and comes first.  CI installs Chromium (.ci/run) and makes this test required there; elsewhere
    it is skipped without one, saying how to get it."""
    out, _ = report
    state = look_at(browser, out / "report.html", screenshot_folder(tmp_path_factory) / "report_fixed.png")
    assert_looks_right(state, len(list(out.glob("*.png"))))
    state = browser.execute_script("""
        const imgs = Array.from(document.images);
        const first = document.querySelector('table');
        return {
          widths: imgs.map(i => i.naturalWidth),
          rows: Array.from(first.tBodies[0].rows).map(r => r.cells[0].textContent),
          tableFirst: !!(first.compareDocumentPosition(imgs[0]) & Node.DOCUMENT_POSITION_FOLLOWING),
          title: document.title,
        };""")
    assert max(state["widths"]) <= 1600
    assert state["rows"] == METHODS and state["tableFirst"], state
    assert state["title"] == "pinid: identification of exo_leg"
    browser.set_window_size(1000, 900)  # a narrow window: wide tables scroll in their block, not the page
    narrow = browser.execute_script(
        "return [document.documentElement.scrollWidth, document.documentElement.clientWidth];"
    )
    assert narrow[0] <= narrow[1], narrow


def _quiet_main(args: list[str]) -> int:
    import contextlib
    import io
    import warnings

    from pinid.cli.main import main

    with (
        contextlib.redirect_stdout(io.StringIO()),
        contextlib.redirect_stderr(io.StringIO()),
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore")
        return main(args)


@pytest.fixture(scope="module")
def floating_report(tmp_path_factory):
    """``pinid identify --base floating`` on a 3 s walk of the floating twin (force plates, 200 Hz)."""
    tmp = tmp_path_factory.mktemp("floating")
    exo = ["--urdf", "exo_lower_body", "--base", "floating"]
    sim = ["simulate", *exo, "--excitation", "gait", "--seconds", "3", "--control-rate", "200", "--no-figures"]
    assert _quiet_main([*sim, "-o", str(tmp / "g.csv")]) == 0
    assert (
        _quiet_main(["identify", *exo, "--data", str(tmp / "g.csv"), "--methods", "ols,sdp", "-o", str(tmp / "r")]) == 0
    )
    return tmp / "r"


@pytest.fixture(scope="module")
def wearer_report(tmp_path_factory):
    """``pinid identify --stage wearer`` on a 4 s noise-free twin of exo_leg with a drawn wearer (docs/wearer.md),
    the stage-1 model the exo's URDF values."""
    from pinid.identification.identified import IdentifiedModel
    from pinid.model.regressor import standard_parameters
    from pinid.model.terms import TermSelection
    from pinid.wearer.attach import wearer_urdf

    tmp = tmp_path_factory.mktemp("wearer")
    (tmp / "eww.urdf").write_text(
        wearer_urdf("exo_leg", "hip:thigh,knee:shank,knee:foot", mass=75, height=1.78, sex="male")
    )
    exo, terms = load("exo_leg"), TermSelection.from_names("fc,fv")
    IdentifiedModel(exo, terms, standard_parameters(exo, terms)).save(tmp / "exo.json")
    excitation = str(Path(__file__).resolve().parents[2] / "excitation" / "exo_leg.json")
    sim = [
        "simulate",
        "--urdf",
        str(tmp / "eww.urdf"),
        "--excitation",
        excitation,
        "--wearer-draw",
        "--control-rate",
        "200",
        "--no-figures",
    ]
    assert _quiet_main([*sim, "--seconds", "4", "--seed", "4", "-o", str(tmp / "rec.csv")]) == 0
    assert _quiet_main([*sim, "--seconds", "3", "--seed", "5", "-o", str(tmp / "val.csv")]) == 0
    stage2 = ["identify", "--stage", "wearer", "--exo", str(tmp / "exo.json"), "--urdf", str(tmp / "eww.urdf")]
    args = [*stage2, "--data", str(tmp / "rec.csv"), "--validate", str(tmp / "val.csv"), "-o", str(tmp / "r")]
    assert _quiet_main(args) == 0
    return tmp / "r"


@pytest.fixture(scope="module")
def compare_report(report, tmp_path_factory):
    """``pinid compare`` (ols, wls) on the fixed report's recordings; its comparison.md with its figures as one
    page (:func:`pinid.report.html.markdown_to_html`, as report.html is made)."""
    out, _ = report
    tmp = tmp_path_factory.mktemp("compare")
    data = ["--data", str(out.parent / "run0.csv"), "--validate", str(out.parent / "run1.csv")]
    assert _quiet_main(["compare", "--urdf", "exo_leg", *data, "--methods", "ols,wls", "-o", str(tmp / "c")]) == 0
    md = (tmp / "c" / "comparison.md").read_text()
    pngs = {p.name: p.read_bytes() for p in (tmp / "c").glob("*.png")}
    (tmp / "c" / "comparison.html").write_text(markdown_to_html(md, pngs, title="pinid: comparison"))
    return tmp / "c"


@pytest.mark.slow  # the floating walk, the wearer's twin and the comparison: 10-20 s with Chromium
@pytest.mark.parametrize("kind", ["floating", "compare", "wearer"])
def test_every_report_kind_looks_right_in_a_browser(kind, request, browser, tmp_path_factory):
    """Issue 47: each kind of report (the fixed base's is the test above) opened in Chromium: every image decodes
    and fits the window, nothing overflows sideways; a full-page screenshot of each is kept
    (``report_<kind>.png`` in $PINID_SCREENSHOTS, else a printed temporary folder)."""
    out = request.getfixturevalue(f"{kind}_report")
    page = out / ("comparison.html" if kind == "compare" else "report.html")
    parsed = Page(page.read_text())
    assert external_resources(parsed) == []
    state = look_at(browser, page, screenshot_folder(tmp_path_factory) / f"report_{kind}.png")
    assert_looks_right(state, parsed.tags.count("img"))
    assert len(list(out.glob("*.png"))) >= 1 and state["images"] >= 1


def test_errors_figure_fits_a_page_and_stays_above_zero():
    """errors.png: one panel per joint (+ all joints) in a grid at most 1600 px wide at the saved resolution;
    the [p5, p95] band of |e| and the x axis start at or above zero even where mean − std would not."""
    from pinid.identification.metrics import torque_metrics
    from pinid.report.figures import DPI
    from pinid.report.plot_identification import error_bars

    rng = np.random.default_rng(0)
    joints = [f"panda_joint{k}" for k in range(1, 8)]
    tau = rng.normal(size=(500, 7))
    methods = [f"m{k}" for k in range(10)]
    # heavy-tailed errors: mean − std of |e| is far below zero
    metrics = {m: torque_metrics(tau, tau + 0.1 * rng.standard_cauchy((500, 7)), joints) for m in methods}
    for d in metrics.values():
        assert d.all["mean_abs"] - d.all["std_abs"] < 0
    fig = error_bars(metrics, title="t")
    width, height = fig.get_size_inches() * DPI
    assert width <= 1600 and height <= 1600, (width, height)
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert sorted(ax.get_title() for ax in panels) == sorted(joints + ["all joints"])
    for ax in panels:
        assert ax.get_xlim()[0] == 0
        for line in ax.lines:
            assert min(line.get_xdata()) >= 0


def test_link_parameter_table_has_units(report):
    """The report's link-parameter table: every column has its unit, friction included (issue 24); the last
    one says which of the values the data determined (issue 33)."""
    out, _ = report
    md = (out / "report.md").read_text()
    section = md.split("## Link parameters", 1)[1].split("\n## ", 1)[0]
    header = next(line for line in section.splitlines() if line.startswith("| joint"))
    cells = [c.strip() for c in header.strip("|").split("|")]
    assert cells[4:] == ["fc [N·m]", "fv [N·m·s/rad]", "from these data"], cells
    assert all("[" in c for c in cells[1:-1]), cells


def test_report_size_is_bounded_by_its_few_figures(report):
    """Issue 33: report.html carries the summary's figures and the best method's torque, not a figure per
    method: its size is the base64 of those five PNGs plus a text that grows by a folded table per method."""
    out, _ = report
    html_size = (out / "report.html").stat().st_size
    pngs = sum(p.stat().st_size for p in out.glob("*.png"))
    assert len(list(out.glob("*.png"))) == 5
    assert html_size <= 4 / 3 * pngs + 60_000, (html_size, pngs)
    assert html_size < 1_500_000


def test_choices_by_cross_validation_are_drawn_and_said(report):
    """--cutoff auto / --terms auto: the report says what was chosen, on which curve, and draws it; a run
    without them has no such section (the choices' dicts as identification.json stores them)."""
    import matplotlib.colors

    from pinid.errors import SpecError
    from pinid.identification.result import Identification
    from pinid.report.markdown import figure_names, report_markdown, shown_figures

    out, _ = report
    ident = Identification.load(out / "identification.json")
    assert "choices" not in shown_figures(ident)
    assert "Chosen by cross-validation" not in report_markdown(ident, figure_names(ident))
    with pytest.raises(SpecError, match="cross-validation"):
        ident.plot("choices")
    ident.data["cutoff"] = {
        "chosen_by": "5-fold blocked cross-validation on the training recordings",
        "cutoff_hz": 10.0,
        "candidates_hz": [5.0, 10.0, 20.0],
        "cv_rel_rms_percent": [4.1, 3.9, None],
        "skipped": {"20": "too few samples"},
    }
    ident.data["terms_choice"] = {
        "chosen_by": "forward selection, 5-fold blocked cross-validation on the training recordings",
        "terms": ["fc", "fv", "offset"],
        "steps": [{"fc,fv": 3.9}, {"+offset": 3.5, "+armature": 3.85}, {"+armature": 3.52}],
    }
    assert "choices" in shown_figures(ident)
    text = report_markdown(ident, figure_names(ident))
    assert "low-pass cut-off **10 Hz**" in text and "5 Hz 4.1 %, 10 Hz 3.9 %" in text
    assert "terms **fc, fv, offset**" in text and "+offset, +armature" in text
    assert "![choices made by cross-validation](cross_validation.png)" in text
    fig = ident.plot("choices")
    cut, terms = fig.axes
    assert list(cut.lines[0].get_xdata()) == [5.0, 10.0]  # the unusable candidate is left out
    assert [t.get_text() for t in terms.get_yticklabels()] == [
        "step 1: +offset",
        "step 1: +armature",
        "step 2: +armature",
    ]
    red = [p.get_width() for p in terms.patches if p.get_facecolor()[:3] == matplotlib.colors.to_rgb("tab:red")]
    assert red == [3.5]  # the candidate added


@pytest.mark.slow  # the floating walk's identification (its fixture): 5-10 s
def test_floating_link_parameters_are_each_bodys_own(floating_report):
    """Issue 47: on a floating base the link-parameter table read the standard vector from index 0 as the first
    joint's, so every row showed the body before it (the pelvis's 8 kg as l_hip_abduction's); each row is its
    body's values by name now, the root link first and without joint terms."""
    import json

    out = floating_report
    md = (out / "report.md").read_text()
    section = md.split("## Link parameters", 1)[1].split("\n## ", 1)[0]
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in section.splitlines() if line.startswith("| `")]
    d = json.loads((out / "identification.json").read_text())
    r = d["methods"][d["best"]]
    value = r["standard_parameters"]
    joints = d["robot"]["joints"]
    assert [row[0] for row in rows] == ["`base` (root link)"] + [f"`{j}`" for j in joints]
    assert rows[0][4:6] == ["–", "–"] and "fc" not in rows[0][-1]  # the free flyer has no friction
    for row, body in zip(rows, ["base"] + joints):
        assert float(row[1]) == pytest.approx(value[f"{body}.m"], rel=1e-3), (body, row)
    for row, j in zip(rows[1:], joints):
        assert float(row[4]) == pytest.approx(value[f"{j}.fc"], rel=1e-3, abs=1e-9), (j, row)
