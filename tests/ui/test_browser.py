"""Issue 9 done-when, in a real browser (system Chromium via Playwright) against the real service:
sign in, upload a simulated set through the form, start a job, watch it reach 100 %, check every plot image
and every product link, zoom an interactive chart, screenshots; team B's pages show nothing of team A's."""
from __future__ import annotations

import json
import re
from pathlib import Path

import httpx
import numpy as np
import pytest

from tests.e2e.conftest import wait_for
from tests.plots.builders import attitude_case, baselines_case, residuals_case
from tests.ui.conftest import sign_in

pytestmark = pytest.mark.e2e
EXPECTED_MEDIA = {".png": "image/png", ".csv": "text/csv", ".json": "application/json", ".html": "text/html",
                  ".zip": "application/zip"}


@pytest.fixture(scope="module")
def simulated_set(tmp_path_factory) -> list[Path]:
    from gnssatt.sim import simulate_scenario

    out = tmp_path_factory.mktemp("sim")
    simulate_scenario("earth-pointing", out, overrides={"duration_s": 120})
    files = sorted(p for p in out.rglob("*") if p.is_file() and "truth" not in p.relative_to(out).parts)
    assert any(p.suffix == ".rnx" for p in files) and any(p.name == "platform.json" for p in files)
    return files


def _chart_x(page, index: int) -> tuple[float, float]:
    return tuple(page.evaluate("i => { const s = GnssattCharts.instances[i].plot.scales.x; return [s.min, s.max]; }",
                               index))


def _drag_zoom(page, index: int, start: float = 0.3, end: float = 0.6) -> None:
    over = page.locator(".chart .u-over").nth(index)
    over.scroll_into_view_if_needed()
    box = over.bounding_box()
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + box["width"] * start, y)
    page.mouse.down()
    page.mouse.move(box["x"] + box["width"] * (start + end) / 2, y, steps=5)
    page.mouse.move(box["x"] + box["width"] * end, y, steps=5)
    page.mouse.up()


def test_upload_run_watch_and_inspect_results(browser, site, simulated_set, artifacts):
    key = site.create_key("ops-ui")
    context, page = sign_in(browser, site, key)
    page.screenshot(path=str(artifacts / "ui-overview-empty.png"), full_page=True)

    # --- upload through the form -------------------------------------------------------------------------
    page.goto("/ui/new")
    page.fill("#set-name", "sim earth-pointing 120 s")
    page.set_input_files("#set-files", [str(p) for p in simulated_set])
    page.click("#upload-button")
    link = page.locator("#uploaded-set")
    link.wait_for(state="visible", timeout=60_000)
    set_id = link.get_attribute("data-set-id")
    assert re.fullmatch(r"[0-9a-f]{32}", set_id)
    # the upload reported its progress: every byte went out (upload "load") before the server's answer,
    # and the bar is put away afterwards
    bar = page.locator("#upload-progress")
    assert bar.get_attribute("data-done") == "1"
    assert page.eval_on_selector("#upload-progress", "b => b.value === b.max")
    assert bar.is_hidden()

    # --- start a job: attitude when the service has it, else inspect ----------------------------------------
    page.wait_for_selector("#job-type[data-loaded='1']")
    types = page.eval_on_selector_all("#job-type option", "os => os.map(o => o.value)")
    job_type = "attitude" if "attitude" in types else "inspect"
    page.select_option("#job-type", job_type)
    config = json.loads(page.input_value("#job-config"))  # filled with the type's defaults
    assert isinstance(config, dict)
    assert page.eval_on_selector_all("#job-sets option:checked", "os => os.map(o => o.value)") == [set_id]
    page.screenshot(path=str(artifacts / "ui-new.png"), full_page=True)
    page.click("#submit-job")
    page.wait_for_url(re.compile(r".*/ui/jobs/[0-9a-f]{32}$"))
    job_id = page.url.rsplit("/", 1)[1]

    # --- watch the progress (SSE) reach 100 %; the page reloads itself with the products ---------------------
    seen: list[float] = []
    page.expose_function("recordProgress", lambda v: seen.append(float(v)))
    page.evaluate("""() => { const bar = document.querySelector('#job-status .js-progress');
        if (!bar) return; window.recordProgress(bar.value);
        new MutationObserver(() => window.recordProgress(bar.value)).observe(bar, {attributes: true}); }""")
    page.wait_for_selector("#products-table", timeout=240_000)
    status = page.locator("#job-status")
    assert status.get_attribute("data-state") == "succeeded", page.locator(".js-problem").inner_text()
    assert page.locator("#job-status .js-percent").inner_text() == "100%"
    assert float(page.eval_on_selector("#job-status .js-progress", "b => b.value")) == 1.0
    assert not seen or max(seen) <= 1.0  # progress seen live (if the job was not already done) never overshoots

    # --- every plot image loads (at least the PNGs the job type declares, and inspect's own) -----------------
    spec = [t for t in page.request.get("/v1/job-types").json() if t["name"] == job_type][0]
    expected_png = {p for p in spec["produces"] if p.endswith(".png")}
    if job_type == "inspect":
        expected_png |= {"tracking.png", "cn0.png"}
    images = page.locator(".plots img")
    n_images = images.count()
    alts = set(page.eval_on_selector_all(".plots img", "imgs => imgs.map(i => i.alt)"))
    assert expected_png <= alts, (expected_png, alts)
    for i in range(n_images):
        images.nth(i).scroll_into_view_if_needed()
    page.wait_for_function("() => Array.from(document.querySelectorAll('.plots img')).every(i => i.complete)")
    widths = page.eval_on_selector_all(".plots img", "imgs => imgs.map(i => [i.alt, i.naturalWidth])")
    assert all(w > 0 for _, w in widths), widths

    # --- every product link downloads non-empty with the right content type -----------------------------------
    links = page.eval_on_selector_all("a.product-link", "as => as.map(a => [a.href, a.dataset.mediaType, "
                                                         "a.getAttribute('download')])")
    assert len(links) >= 5
    for href, media_type, name in links:
        resp = page.request.get(href)  # the browser context's cookie, as a click would send it
        assert resp.status == 200, (name, resp.status)
        assert len(resp.body()) > 0, name
        ctype = resp.headers["content-type"].split(";")[0]
        assert ctype == media_type == EXPECTED_MEDIA.get(Path(name).suffix, media_type), (name, ctype)
        assert name in resp.headers.get("content-disposition", "")
    with page.expect_download() as dl:
        page.locator("a.product-link").first.click()
    assert Path(dl.value.path()).stat().st_size > 0

    # --- zoom an interactive chart, and the others follow -----------------------------------------------------
    page.wait_for_function("() => Number(document.getElementById('charts').dataset.ready || 0) > 0")
    n_charts = page.evaluate("GnssattCharts.instances.length")
    assert n_charts >= 2
    before = _chart_x(page, 0)
    _drag_zoom(page, 0)
    after = _chart_x(page, 0)
    assert after != before and after[1] - after[0] < 0.5 * (before[1] - before[0]), (before, after)
    assert before[0] <= after[0] < after[1] <= before[1]
    assert _chart_x(page, 1) == pytest.approx(after)  # shared time axis
    # hover shows values in the legend
    over = page.locator(".chart .u-over").first
    box = over.bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    values = page.locator(".chart").first.locator(".u-legend .u-value").all_inner_texts()
    assert any(re.search(r"\d", v) for v in values[1:]), values
    # double-click resets the zoom
    over.dblclick()
    assert _chart_x(page, 0) == pytest.approx(before, abs=1.0)
    page.screenshot(path=str(artifacts / f"ui-job-{job_type}.png"), full_page=True)
    assert page.console_errors == [], page.console_errors

    # --- the other pages --------------------------------------------------------------------------------------
    page.goto("/ui")
    assert page.locator(f"tr.job[data-job-id='{job_id}'] .state").inner_text() == "succeeded"
    assert page.locator(f"tr.set[data-set-id='{set_id}']").count() == 1
    page.screenshot(path=str(artifacts / "ui-overview.png"), full_page=True)
    page.goto(f"/ui/sets/{set_id}")
    assert page.locator("#files-table tbody tr").count() == len(simulated_set)
    assert "GPS-0.rnx" in page.locator("#files-table").inner_text()
    page.screenshot(path=str(artifacts / "ui-set.png"), full_page=True)
    page.goto("/ui/pcv-maps")
    page.screenshot(path=str(artifacts / "ui-pcv-maps.png"), full_page=True)
    assert page.console_errors == [], page.console_errors
    context.close()


def test_attitude_charts_from_csv_products(browser, site, simulated_set, artifacts):
    """The attitude job's CSV products (CONVENTIONS.md columns) charted by the same code the job page uses,
    served here through routed URLs so the test does not depend on the attitude pipeline."""
    key = site.create_key("charts-ui")
    with httpx.Client(base_url=site.url, headers={"Authorization": f"Bearer {key}"}, timeout=60) as c:
        files = [("files", (p.name, p.read_bytes(), "application/octet-stream")) for p in simulated_set]
        set_id = c.post("/v1/observation-sets", files=files).json()["id"]
        job_id = c.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": [set_id]}).json()["id"]
        wait_for(lambda: c.get(f"/v1/jobs/{job_id}").json()["state"] == "succeeded", 120, what="inspect job")
    context, page = sign_in(browser, site, key)
    att, _, _, truth = attitude_case(n=90, float_epochs=range(0, 6))
    lines = att.splitlines()
    att = "\n".join([lines[0] + ",yaw_error_deg,pitch_error_deg,roll_error_deg"]
                    + [ln + ",0.1,-0.2,0.05" for ln in lines[1:]]) + "\n"
    residuals, _ = residuals_case(n=90)
    products = {"attitude.csv": att, "residuals.csv": residuals, "baselines.csv": baselines_case(n=90)}
    def serve(body: str):
        return lambda route, *_: route.fulfill(status=200, body=body, content_type="text/csv")

    for name, body in products.items():
        page.route(f"**/fake/{name}", serve(body))
    page.goto(f"/ui/jobs/{job_id}")
    page.wait_for_function("() => Number(document.getElementById('charts').dataset.ready || 0) > 0")
    n = page.evaluate("""async (names) => {
        GnssattCharts.instances.length = 0;
        const box = document.getElementById('charts'); box.replaceChildren();
        return await GnssattCharts.mount(box, names.map(n => ({name: n, url: '/fake/' + n})));
    }""", list(products))
    titles = page.evaluate("GnssattCharts.instances.map(c => c.title)")
    assert n == len(titles) and {"Euler angles (3-2-1) [deg]", "Fix status and satellites used",
                                 "Euler angle errors (estimate − reference) [deg]",
                                 "Phase residual RMS per epoch [mm]", "Code residual RMS per epoch [m]",
                                 "Baseline azimuth (heading) [deg]", "Baselines fixed (1) / float (0)"} <= set(titles)
    euler = titles.index("Euler angles (3-2-1) [deg]")
    pitch = page.evaluate(f"GnssattCharts.instances[{euler}].plot.data[2]")
    assert pitch == pytest.approx(list(truth["pitch"] - 0.2), abs=1e-6)
    fix = page.evaluate(f"GnssattCharts.instances[{titles.index('Fix status and satellites used')}].plot.data")
    assert fix[2] == list(map(float, truth["fixed"])) and fix[1] == list(map(float, truth["n_sats"]))
    before = _chart_x(page, euler)
    _drag_zoom(page, euler, 0.2, 0.5)
    after = _chart_x(page, euler)
    assert after[1] - after[0] < 0.5 * (before[1] - before[0])
    assert all(_chart_x(page, i) == pytest.approx(after) for i in range(len(titles)))
    page.screenshot(path=str(artifacts / "ui-attitude-charts.png"), full_page=True)
    context.close()


def test_upload_error_shows_problem_with_file_and_line(browser, site, tmp_path):
    key = site.create_key("errors-ui")
    context, page = sign_in(browser, site, key)
    bad = tmp_path / "broken.rnx"
    bad.write_text(f"{'3.04':>9}{'':11}{'OBSERVATION DATA':<20}{'G (GPS)':<20}RINEX VERSION / TYPE\ngarbage\n")
    page.goto("/ui/new")
    page.set_input_files("#set-files", [str(bad)])
    page.click("#upload-button")
    box = page.locator("#upload-form + .js-problem")
    box.wait_for(state="visible")
    text = box.inner_text()
    assert "broken.rnx could not be read" in text and "file broken.rnx, line 3" in text
    # an invalid config: the 422 problem names the field
    page.wait_for_selector("#job-type[data-loaded='1']")
    page.select_option("#job-type", "selftest")
    page.fill("#job-config", '{"duration_s": -1}')
    page.click("#submit-job")
    problem = page.locator("#job-form + .js-problem")
    problem.wait_for(state="visible")
    assert "Invalid config" in problem.inner_text() and "config.duration_s" in problem.inner_text()
    context.close()


def test_team_b_pages_show_nothing_of_team_a(browser, site, simulated_set, artifacts):
    key_a, key_b = site.create_key("team-a-ui"), site.create_key("team-b-ui")
    with httpx.Client(base_url=site.url, headers={"Authorization": f"Bearer {key_a}"}, timeout=60) as c:
        files = [("files", (p.name, p.read_bytes(), "application/octet-stream")) for p in simulated_set]
        obs_set = c.post("/v1/observation-sets", files=files, data={"name": "secret-set-of-a"}).json()
        job = c.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": [obs_set["id"]]}).json()
        wait_for(lambda: c.get(f"/v1/jobs/{job['id']}").json()["state"] == "succeeded", 120, what="inspect job")
    context, page = sign_in(browser, site, key_b)
    overview = page.content()
    for secret in (obs_set["id"], obs_set["id"][:8], job["id"][:8], "secret-set-of-a"):
        assert secret not in overview
    page.screenshot(path=str(artifacts / "ui-team-b-overview.png"), full_page=True)
    for url in (f"/ui/jobs/{job['id']}", f"/ui/sets/{obs_set['id']}"):
        resp = page.goto(url)
        assert resp.status == 404 and "not found" in page.inner_text("h1")
        assert "secret-set-of-a" not in page.content() and "tracking.png" not in page.content()
    for url in (f"/v1/jobs/{job['id']}/products/tracking.png", f"/v1/observation-sets/{obs_set['id']}",
                f"/v1/jobs/{job['id']}/events"):
        assert page.request.get(url).status == 404
    page.goto("/ui/new")
    assert obs_set["id"] not in page.content()
    assert page.locator("#job-sets option").count() == 0
    page.goto("/ui/pcv-maps")
    assert page.locator("#pcv-none").is_visible()
    context.close()


def test_pcv_map_page_reads_out_the_bin_under_the_pointer(browser, site, artifacts):
    """The polar view of an uploaded map: pointing at a bin shows that bin's value, sigma and count; an empty
    bin says empty; the canvas draws the filled bins in colour and the empty ones grey."""
    import math

    from tests.gnss.test_pcv_map import make_map

    key = site.create_key("ops-pcv")
    grid = make_map(seed=3)
    resp = httpx.post(f"{site.url}/v1/pcv-maps", json={"name": "gap-l2", "map": grid.to_json()},
                      headers={"Authorization": f"Bearer {key}"})
    assert resp.status_code == 201, resp.text
    map_id = resp.json()["id"]
    context, page = sign_in(browser, site, key)
    page.goto("/ui/pcv-maps")
    page.click(f"a[href='/ui/pcv-maps/{map_id}']")
    page.wait_for_selector("#pcv-polar[data-ready='1']")
    canvas = page.locator("#pcv-polar")
    box = canvas.bounding_box()
    size = page.eval_on_selector("#pcv-polar", "c => [c.width, c.height]")
    scale = box["width"] / size[0]
    r_px = size[0] / 2 - 22  # the page's plot radius (elevation 0 on the circle), canvas pixels

    def point_at(i_el: int, j_az: int) -> str:
        el, az = grid.elevation_deg[i_el], grid.azimuth_deg[j_az]
        r = r_px * (90 - el) / 90
        a = math.radians(az - 90)
        page.mouse.move(box["x"] + (size[0] / 2 + r * math.cos(a)) * scale,
                        box["y"] + (size[1] / 2 + r * math.sin(a)) * scale)
        readout = page.locator("#pcv-readout")
        assert readout.get_attribute("data-bin") == f"{i_el},{j_az}"
        return readout.inner_text()

    # bins between 5 and 50 deg elevation are several canvas pixels wide each way: a pointer at the centre is inside
    usable = ((grid.elevation_deg > 5) & (grid.elevation_deg < 50))[:, None]
    filled = np.argwhere(np.isfinite(grid.values_mm) & usable)
    for i, j in filled[:: max(1, len(filled) // 5)][:5]:
        text = point_at(int(i), int(j))
        assert f"{grid.values_mm[i, j]:.2f} ± {grid.sigma_mm[i, j]:.2f} mm ({grid.count[i, j]} samples)" in text
    i, j = np.argwhere(np.isnan(grid.values_mm) & usable)[0]
    assert f"empty ({grid.count[i, j]} samples)" in point_at(int(i), int(j))
    page.screenshot(path=str(artifacts / "ui-pcv-map.png"), full_page=True)
    assert page.console_errors == [], page.console_errors
    context.close()


def _walk(schema: dict, node: dict, prefix: str = ""):
    """(path, resolved property) of every field of a pydantic JSON schema, nested objects included ($ref and
    Optional's anyOf resolved, as the page resolves them)."""
    def resolve(p):
        while "$ref" in p:
            p = {**schema["$defs"][p["$ref"].split("/")[-1]], **{k: v for k, v in p.items() if k != "$ref"}}
        alt = [a for a in p.get("anyOf", []) if a.get("type") != "null"]
        return {**resolve(alt[0]), **{k: v for k, v in p.items() if k != "anyOf"}} if len(alt) == 1 else p
    for name, raw in resolve(node).get("properties", {}).items():
        p = resolve(raw)
        path = f"{prefix}.{name}" if prefix else name
        yield path, p
        if "properties" in p:
            yield from _walk(schema, p, path)


def _js_number(x) -> str:
    """A number as JavaScript's String() writes it: positional from 1e-7 to 1e21 (shortest round-trip digits)."""
    import numpy as np
    x = float(x)
    if x == 0 or 1e-7 <= abs(x) < 1e21:
        return np.format_float_positional(x, trim="-")
    return repr(x).replace("e-0", "e-").replace("e+0", "e+")


def _range_text(p: dict) -> str:
    lo = f"[{_js_number(p['minimum'])}" if "minimum" in p else (
        f"({_js_number(p['exclusiveMinimum'])}" if "exclusiveMinimum" in p else "(-inf")
    hi = f"{_js_number(p['maximum'])}]" if "maximum" in p else (
        f"{_js_number(p['exclusiveMaximum'])})" if "exclusiveMaximum" in p else "inf)")
    return f"{lo}, {hi}"


def test_config_help_lists_every_field_nested_ones_too_with_its_range_and_default(browser, site):
    """The job form's "configuration fields" list (issue 24 item 8): every field of the chosen type's config,
    nested objects as nested lists, each with its type or allowed values, its range from the schema's own bounds,
    its default and its description; checked for the types with the deepest configs."""
    key = site.create_key("ops-help")
    context, page = sign_in(browser, site, key)
    page.goto("/ui/new")
    page.wait_for_selector("#job-type[data-loaded='1']")
    specs = {t["name"]: t for t in page.request.get("/v1/job-types").json()}
    page.click("summary:has-text('configuration fields')")  # opened as a user opens it
    for job_type in ("attitude", "ttff", "gyro-fusion"):
        page.select_option("#job-type", job_type)
        schema = specs[job_type]["config_schema"]
        fields = list(_walk(schema, schema))
        nested = [f for f, _ in fields if "." in f]
        assert job_type == "gyro-fusion" or nested, f"{job_type}: expected nested fields"
        shown = page.eval_on_selector_all(".js-config-help li", "ls => ls.map(l => l.dataset.field)")
        assert shown == [f for f, _ in fields]
        for path, p in fields:
            item = page.locator(f'.js-config-help li[data-field="{path}"]').first
            facts = item.locator(".js-field-facts")  # the item's own comes before its nested list's
            text = facts.first.inner_text() if facts.count() else ""
            if any(k in p for k in ("minimum", "exclusiveMinimum", "maximum", "exclusiveMaximum")):
                assert f"range {_range_text(p)}" in text, (path, text)
            if "enum" in p:
                assert all(f'"{v}"' in text for v in p["enum"] if isinstance(v, str)), (path, text)
            if "default" in p and isinstance(p["default"], (int, float, str)) and not isinstance(p["default"], bool):
                default = _js_number(p["default"]) if isinstance(p["default"], (int, float)) else f'"{p["default"]}"'
                assert f"default {default}" in text, (path, text)
            if p.get("description"):
                assert " ".join(p["description"].split()) in " ".join(item.inner_text().split()), path
    assert page.console_errors == []
    context.close()
