"""Issue 24 done-when, in the system Chromium against the real service (API + worker subprocesses): an attitude
job's page shows the quality verdict, the reference overlaid on the Euler angles, error charts against the
reference, float epochs shaded with the y range on fixed epochs, zoom shared by every chart, GPS/UTC time, no
horizontal overflow at 1366 and 420 px (also with a long error message), the report inline, its PDF and the
"download all" zip."""
from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import httpx
import pytest

from tests.e2e.conftest import wait_for
from tests.ui.conftest import sign_in

pytestmark = pytest.mark.e2e
WIDTHS = (1366, 420)


@pytest.fixture(scope="module")
def attitude_job(site, tmp_path_factory):
    from gnssatt.sim import simulate_scenario

    out = tmp_path_factory.mktemp("sim300")
    simulate_scenario("earth-pointing", out, overrides={"duration_s": 300})
    files = sorted(p for p in out.rglob("*") if p.is_file() and "truth" not in p.relative_to(out).parts)
    key = site.create_key("pages-ui")
    with httpx.Client(base_url=site.url, headers={"Authorization": f"Bearer {key}"}, timeout=120) as c:
        up = [("files", (str(p.relative_to(out)), p.read_bytes(), "application/octet-stream")) for p in files]
        set_id = c.post("/v1/observation-sets", files=up, data={"name": "sim 300 s"}).json()["id"]
        resp = c.post("/v1/jobs", json={"type": "attitude", "observation_set_ids": [set_id]})
        assert resp.status_code == 202, resp.text
        job_id = resp.json()["id"]
        wait_for(lambda: c.get(f"/v1/jobs/{job_id}").json()["state"] in ("succeeded", "failed"), 240,
                 what="attitude job")
        job = c.get(f"/v1/jobs/{job_id}").json()
        assert job["state"] == "succeeded", job
        summary = c.get(f"/v1/jobs/{job_id}/products/summary.json").json()
    return {"key": key, "job_id": job_id, "set_id": set_id, "summary": summary, "dir": out}


def _overflow(page) -> int:
    return page.evaluate("document.documentElement.scrollWidth - window.innerWidth")


def _wide(page) -> list[str]:
    """The deepest elements that reach past the window's right edge (the message of an overflow failure)."""
    return page.evaluate("""() => Array.from(document.querySelectorAll('body *')).filter(e => {
        const r = e.getBoundingClientRect(); return r.right > window.innerWidth + 1 && r.width > 0 &&
        !Array.from(e.children).some(c => c.getBoundingClientRect().right > window.innerWidth + 1); })
        .slice(0, 8).map(e => e.tagName + '.' + e.className + ' ' + Math.round(e.getBoundingClientRect().right))""")


@pytest.mark.parametrize("width", WIDTHS)
def test_job_page_verdict_overlay_zoom(browser, site, attitude_job, artifacts, width):
    context, page = sign_in(browser, site, attitude_job["key"])
    page.set_viewport_size({"width": width, "height": 900})
    page.goto(f"/ui/jobs/{attitude_job['job_id']}")
    page.wait_for_function("() => Number(document.getElementById('charts').dataset.ready || 0) > 0")
    q = attitude_job["summary"]["quality"]
    assert page.inner_text("#quality-verdict").strip().lower() == q["verdict"]
    rows = page.eval_on_selector_all("#quality-table tbody tr", "rs => rs.map(r => [r.dataset.key, r.dataset.verdict])")
    assert rows == [[it["key"], it["verdict"]] for it in q["items"]]
    assert page.locator("#raw-summary").count() == 1          # the raw keys one click away
    charts = page.evaluate("GnssattCharts.instances.map(c => ({id: c.id, title: c.title, n: c.plot.series.length,"
                           " labels: c.plot.series.map(s => s.label), spans: c.floatSpans.length}))")
    by_id = {c["id"]: c for c in charts}
    assert {"euler", "errors", "sigma", "fix", "residual_mm", "residual_m"} <= set(by_id)
    assert {"yaw reference", "pitch reference", "roll reference"} <= set(by_id["euler"]["labels"])
    assert by_id["euler"]["spans"] > 0                        # the pass starts float: shaded
    # every chart drew (a canvas of its width), none wider than the window
    assert page.evaluate("GnssattCharts.instances.every(c => c.plot.width > 200 && c.plot.width <= window.innerWidth)")
    # y range of the Euler errors from the fixed epochs: the float start (errors of tens of degrees) is outside
    i = [c["id"] for c in charts].index("errors")
    y = page.evaluate(f"(() => {{ const p = GnssattCharts.instances[{i}].plot; return [p.scales.y.min, p.scales.y.max]; }})()")
    fixed_max = max(abs(it["value"]["max_abs_deg"]) for it in q["items"] if it["key"].endswith("_vs_reference"))
    assert y[1] - y[0] < 2.5 * 2 * fixed_max + 1e-9
    # zoom by drag on the first chart: every chart follows
    over = page.locator(".chart .u-over").first
    over.scroll_into_view_if_needed()
    box = over.bounding_box()
    x0 = page.evaluate("[GnssattCharts.instances[0].plot.scales.x.min, GnssattCharts.instances[0].plot.scales.x.max]")
    page.mouse.move(box["x"] + box["width"] * 0.3, box["y"] + box["height"] / 2)
    page.mouse.down()
    page.mouse.move(box["x"] + box["width"] * 0.6, box["y"] + box["height"] / 2, steps=6)
    page.mouse.up()
    ranges = page.evaluate("GnssattCharts.instances.map(c => [c.plot.scales.x.min, c.plot.scales.x.max])")
    assert ranges[0][1] - ranges[0][0] < 0.5 * (x0[1] - x0[0])
    assert all(abs(r[0] - ranges[0][0]) < 1e-6 and abs(r[1] - ranges[0][1]) < 1e-6 for r in ranges)
    # UTC instead of GPS time: axis label and legend change, GPS - UTC = 18 s in 2018
    page.select_option("#time-system", "UTC")
    assert page.evaluate("GnssattCharts.instances[0].plot.axes[0].label").startswith("UTC")
    assert page.evaluate("GnssattCharts.clock.leap") == 18
    legend_time = page.inner_text(".chart .u-legend .u-series:first-child .u-value").strip()
    assert legend_time == "–" or legend_time.endswith("UTC"), legend_time
    page.screenshot(path=str(artifacts / f"ui-job-attitude-{width}.png"), full_page=True)
    assert _overflow(page) <= 0, (f"horizontal overflow at {width} px", _wide(page))
    assert page.console_errors == [], page.console_errors
    context.close()


def test_report_inline_pdf_and_download_all(browser, site, attitude_job):
    context, page = sign_in(browser, site, attitude_job["key"])
    page.goto(f"/ui/jobs/{attitude_job['job_id']}")
    href = page.get_attribute("#report-link", "href")
    resp = context.request.get(href)
    assert resp.status == 200 and resp.headers["content-type"].startswith("text/html")
    assert resp.headers["content-disposition"].startswith("inline")
    html = resp.text()
    assert "Quality" in html and attitude_job["summary"]["quality"]["verdict"] in html
    report = context.new_page()
    report.goto(href)
    assert report.locator("img").count() >= 3
    assert report.evaluate("Array.from(document.images).every(i => i.naturalWidth > 0)")
    pdf = context.request.get(page.get_attribute("#report-pdf", "href"), timeout=120_000)
    assert pdf.status == 200 and pdf.headers["content-type"] == "application/pdf"
    assert pdf.body()[:5] == b"%PDF-" and len(pdf.body()) > 20_000
    z = context.request.get(page.get_attribute("#download-all", "href"))
    assert z.status == 200
    names = zipfile.ZipFile(io.BytesIO(z.body())).namelist()
    assert {"config.json", "versions.json", "products/summary.json", "products/report.html",
            "products/attitude.aem", "products/charts.json"} <= set(names)
    versions = json.loads(zipfile.ZipFile(io.BytesIO(z.body())).read("versions.json"))
    assert versions["software"]["numpy"] and versions["inputs"][0]["set_id"] == attitude_job["set_id"]
    assert all(len(f["sha256"]) == 64 for f in versions["inputs"][0]["files"])
    context.close()


@pytest.mark.parametrize("width", WIDTHS)
def test_long_error_message_does_not_overflow(browser, site, attitude_job, width):
    from sqlalchemy import update

    from core.db import make_engine, make_sessionmaker
    from core.models import Job
    from core.settings import Settings

    settings = Settings(data_dir=Path(site.env["GNSSATT_DATA_DIR"]))
    engine = make_engine(settings)
    with make_sessionmaker(engine).begin() as s:
        job = s.get(Job, attitude_job["job_id"])
        long_id = "x" * 40 + "/" + "y" * 300
        err = {"title": "Unreadable observation file " + "z" * 200, "detail": "no epoch line " * 40 + long_id,
               "file": "obs/" + "a" * 250 + ".rnx", "line": 12, "field": "config." + "b" * 200}
        new = Job(team_id=job.team_id, type="attitude", state="failed", config={"note": "c" * 400},
                  set_ids=list(job.set_ids), error=err, progress=0.3)
        s.add(new)
        s.flush()
        failed_id = new.id
    engine.dispose()
    context, page = sign_in(browser, site, attitude_job["key"])
    page.set_viewport_size({"width": width, "height": 900})
    page.goto(f"/ui/jobs/{failed_id}")
    assert page.locator(".js-problem").is_visible()
    assert _overflow(page) <= 0, (f"horizontal overflow at {width} px with a long error", _wide(page))
    context.close()


def test_sign_in_link_with_the_key_in_the_fragment_opens_the_job_page(browser, site, attitude_job):
    """`make demo`'s last lines: /ui/login?next=/ui/jobs/ID#key=KEY signs in and lands on the job page; the key
    never reaches the server (fragment), and the address bar forgets it."""
    from client.demo import final_lines

    page_line = final_lines(site.url, attitude_job["key"], attitude_job["job_id"], Path("/nonexistent"))[0]
    url = page_line.split(": ", 1)[1]
    context = browser.new_context()
    page = context.new_page()
    seen: list[str] = []
    page.on("request", lambda r: seen.append(r.url))
    page.goto(url)
    page.wait_for_url(f"{site.url}/ui/jobs/{attitude_job['job_id']}")
    assert page.locator("#quality-verdict").is_visible()
    assert not any(attitude_job["key"] in u for u in seen)
    context.close()


def test_platform_writer_adds_a_platform_json_the_service_accepts(browser, site, attitude_job):
    """/ui/new: without a platform.json, the form writes one (CONVENTIONS.md layout) into the upload; the set is
    accepted with its antennas matched, and an attitude job on it passes the early checks."""
    d = attitude_job["dir"]
    plat = json.loads((d / "platform.json").read_text())
    files = [p for p in sorted(d.rglob("*")) if p.is_file() and "truth" not in p.relative_to(d).parts
             and p.name != "platform.json"]
    context, page = sign_in(browser, site, attitude_job["key"])
    page.goto("/ui/new")
    page.click("#platform-writer summary")
    page.fill("#pf-name", "written in the browser")
    rows = page.locator("#pf-antennas tbody tr")
    assert rows.count() == 3
    for i, (ant, spec) in enumerate(plat["antennas"].items()):
        row = rows.nth(i)
        row.locator(".pf-id").fill(ant)
        for k in range(3):
            row.locator(f".pf-p{k}").fill(repr(spec["position_m"][k]))
    written = json.loads(page.inner_text("#pf-preview"))
    assert written["antennas"] == {a: {"position_m": s["position_m"], "boresight": [0, 0, -1]}
                                   for a, s in plat["antennas"].items()}
    assert written["master"] == next(iter(plat["antennas"])) and len(written["baselines"]) == 2
    page.set_input_files("#set-files", [str(p) for p in files])
    page.click("#pf-use")
    names = page.eval_on_selector("#set-files", "i => Array.from(i.files).map(f => f.name)")
    assert "platform.json" in names and len(names) == len(files) + 1
    page.fill("#set-name", "platform from the form")
    page.click("#upload-button")
    page.locator("#uploaded-set").wait_for(state="visible", timeout=60_000)
    set_id = page.get_attribute("#uploaded-set", "data-set-id")
    with httpx.Client(base_url=site.url, headers={"Authorization": f"Bearer {attitude_job['key']}"}) as c:
        summary = c.get(f"/v1/observation-sets/{set_id}").json()["summary"]
        assert summary["platform"] == "written in the browser" and set(summary["antennas"]) == set(plat["antennas"])
        # the template link serves the CONVENTIONS example
        assert c.get("/static/platform-template.json").json()["antennas"]
    # the form refuses an incomplete platform: one antenna
    page.goto("/ui/new")
    page.click("#platform-writer summary")
    page.locator("#pf-antennas .pf-remove").first.click()
    page.locator("#pf-antennas .pf-remove").first.click()
    assert "at least two antennas" in page.inner_text(".js-pf-problem")
    context.close()
